#include "app/rank_zero.hpp"

#include <exception>
#include <stdexcept>

#include "app/exit_status.hpp"

namespace capsflow::app {

void on_root(const parallel::Comm& comm, const std::function<void()>& work) {
  if (!comm.distributed()) {
    work();
    return;
  }
  std::exception_ptr error;
  int status = 0;
  if (comm.is_root()) {
    try {
      work();
    } catch (...) {
      error = std::current_exception();
      status = exit_status_of(error, "").status;
    }
  }
  if (MPI_Bcast(&status, 1, MPI_INT, 0, comm.handle()) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Bcast of rank 0's status failed");
  if (error) std::rethrow_exception(error);
  if (status != 0) throw OtherRankFailed(status);
}

}  // namespace capsflow::app
