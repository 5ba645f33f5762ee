#include "parallel/all_or_none.hpp"

#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "parallel/collective_counts.hpp"

namespace capsflow::parallel {

void all_or_none(const Comm& comm, const std::function<void()>& work) {
  if (!comm.distributed()) {
    work();
    return;
  }
  std::string message;
  bool failed = false;
  try {
    work();
  } catch (const std::exception& e) {
    failed = true;
    message = e.what();
  } catch (...) {
    failed = true;
    message = "an unknown error";
  }
  int first = failed ? comm.rank() : comm.size();
  detail::count_reduction();
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm.handle());
  if (first == comm.size()) return;
  int length = static_cast<int>(message.size());
  MPI_Bcast(&length, 1, MPI_INT, first, comm.handle());
  std::vector<char> text(static_cast<std::size_t>(length));
  if (comm.rank() == first) message.copy(text.data(), text.size());
  MPI_Bcast(text.data(), length, MPI_CHAR, first, comm.handle());
  throw std::runtime_error(std::string(text.begin(), text.end()));
}

}  // namespace capsflow::parallel
