#pragma once
// Who runs alongside this process. A run started by a launcher (mpirun, mpiexec, srun) is a
// set of MPI ranks; a run started on its own is one rank and makes no MPI call at all: a
// singleton MPI_Init costs about 0.45 s here (it starts Open MPI's runtime), which a serial
// user, and every test that runs the binary, would pay for nothing.
#include <mpi.h>

namespace capsflow::parallel {

class Comm {
 public:
  // The ranks of this run: MPI_COMM_WORLD once an MpiSession has initialised MPI, else one
  // rank with no communicator.
  static Comm world();
  // One rank, no communicator (serial work inside a distributed run).
  static Comm self() { return Comm(MPI_COMM_NULL, 0, 1); }

  [[nodiscard]] int rank() const { return rank_; }
  [[nodiscard]] int size() const { return size_; }
  [[nodiscard]] bool is_root() const { return rank_ == 0; }
  // Whether calls go through MPI (false for one rank without a communicator).
  [[nodiscard]] bool distributed() const { return handle_ != MPI_COMM_NULL; }
  [[nodiscard]] MPI_Comm handle() const { return handle_; }
  void barrier() const;
  // Ranks of this communicator on this rank's node (shared memory): 1 without MPI. Collective.
  [[nodiscard]] int ranks_on_this_node() const;

 private:
  Comm(MPI_Comm handle, int rank, int size) : handle_(handle), rank_(rank), size_(size) {}
  MPI_Comm handle_;
  int rank_;
  int size_;
};

// Whether this process was started by an MPI launcher (it then must call MPI_Init).
[[nodiscard]] bool launched_by_mpi();

// Initialises MPI (threads: funneled, OpenMP regions make no MPI call) when the process was
// started by a launcher, and finalises it at scope exit. One per process, in main().
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  [[nodiscard]] bool active() const { return active_; }

 private:
  bool active_ = false;
};

}  // namespace capsflow::parallel
