#include "parallel/reduce.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "parallel/collective_counts.hpp"

namespace capsflow::parallel {

namespace {

void check(int code, const char* what) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  throw std::runtime_error(fmt::format("{} failed: {}", what, std::string(text, static_cast<std::size_t>(length))));
}

// MPI_MAX / MPI_MIN on doubles compare with < and drop NaN depending on the order; these
// keep it, whatever the order.
template <bool Max>
void nan_keeping_extremum(void* in, void* inout, int* len, MPI_Datatype*) {
  const auto* a = static_cast<const double*>(in);
  auto* b = static_cast<double*>(inout);
  for (int i = 0; i < *len; ++i) {
    if (std::isnan(b[i])) continue;
    if (std::isnan(a[i]) || (Max ? a[i] > b[i] : a[i] < b[i])) b[i] = a[i];
  }
}

template <bool Max>
MPI_Op nan_keeping_op() {
  static MPI_Op op = [] {
    MPI_Op o = MPI_OP_NULL;
    check(MPI_Op_create(&nan_keeping_extremum<Max>, 1, &o), "MPI_Op_create");
    return o;
  }();
  return op;
}

// In place, counted (collective_counts.hpp).
void allreduce(void* values, int count, MPI_Datatype type, MPI_Op op, const Comm& comm, const char* what) {
  detail::count_reduction();
  check(MPI_Allreduce(MPI_IN_PLACE, values, count, type, op, comm.handle()), what);
}

}  // namespace

double global_sum(const Comm& comm, const ExactSum& local) {
  if (!comm.distributed()) return local.value();
  auto words = local.words();
  allreduce(words.data(), ExactSum::kWords, MPI_INT64_T, MPI_SUM, comm, "MPI_Allreduce (sum)");
  return ExactSum::from_words(words).value();
}

std::int64_t global_sum(const Comm& comm, std::int64_t local) {
  if (comm.distributed())
    allreduce(&local, 1, MPI_INT64_T, MPI_SUM, comm, "MPI_Allreduce (sum)");
  return local;
}

double global_max(const Comm& comm, double local) {
  if (comm.distributed())
    allreduce(&local, 1, MPI_DOUBLE, nan_keeping_op<true>(), comm, "MPI_Allreduce (max)");
  return local;
}

double global_min(const Comm& comm, double local) {
  if (comm.distributed())
    allreduce(&local, 1, MPI_DOUBLE, nan_keeping_op<false>(), comm, "MPI_Allreduce (min)");
  return local;
}

std::int64_t global_max(const Comm& comm, std::int64_t local) {
  if (comm.distributed())
    allreduce(&local, 1, MPI_INT64_T, MPI_MAX, comm, "MPI_Allreduce (max)");
  return local;
}

bool global_any(const Comm& comm, bool local) {
  int v = local ? 1 : 0;
  if (comm.distributed())
    allreduce(&v, 1, MPI_INT, MPI_LOR, comm, "MPI_Allreduce (any)");
  return v != 0;
}

}  // namespace capsflow::parallel
