#include "parallel/comm.hpp"

#include <cstdlib>
#include <stdexcept>

#include <fmt/format.h>

namespace capsflow::parallel {

bool launched_by_mpi() {
  // Open MPI's mpirun, PMIx-based launchers (Slurm's srun, prrte) and MPICH's Hydra each set
  // one of these in every rank's environment.
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "PMI_RANK"})
    if (std::getenv(name) != nullptr) return true;
  return false;
}

Comm Comm::world() {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized) return self();
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return {MPI_COMM_WORLD, rank, size};
}

void Comm::barrier() const {
  if (distributed()) MPI_Barrier(handle_);
}

int Comm::ranks_on_this_node() const {
  if (!distributed()) return 1;
  MPI_Comm node = MPI_COMM_NULL;
  if (MPI_Comm_split_type(handle_, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Comm_split_type (ranks on this node) failed");
  int n = 1;
  MPI_Comm_size(node, &n);
  MPI_Comm_free(&node);
  return n;
}

namespace {

// Open MPI's shared-memory transport (vader) sends a message above 4 KB by rendezvous: the
// sender announces it, waits for the receiver to answer, then a system call (CMA) copies it.
// A flow step's exchanges are mostly 1-30 KB (one level's ghosts, or one colour of them);
// each cost 10-34 us that way against 2-8 us sent eagerly (copied through the shared
// segment, no handshake: a sender that arrives first does not wait for its receiver).
// Measured on the seed shell, 2 ranks: bench/parallel/mpi_scaling.sh, docs/parallel.md.
// Set before MPI_Init, and only where the user has not (mpirun --mca or the environment
// win); other MPI libraries ignore the variable.
void prefer_eager_shared_memory_messages() {
  setenv("OMPI_MCA_btl_vader_eager_limit", "32768", /*overwrite=*/0);
}

}  // namespace

MpiSession::MpiSession(int& argc, char**& argv) {
  if (!launched_by_mpi()) return;
  prefer_eager_shared_memory_messages();
  int provided = 0;
  if (MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Init_thread failed");
  if (provided < MPI_THREAD_FUNNELED) {
    MPI_Finalize();
    throw std::runtime_error(fmt::format("MPI provides thread level {}, capsflow needs MPI_THREAD_FUNNELED", provided));
  }
  // Errors are values here: a failed call returns its code to the caller, which throws.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  active_ = true;
}

MpiSession::~MpiSession() {
  if (active_) MPI_Finalize();
}

}  // namespace capsflow::parallel
