// main() of the tests that run under mpiexec: MPI around GoogleTest, output from rank 0
// only (a failure on another rank still fails that rank's exit status, so the launcher's).
#include <gtest/gtest.h>

#include "parallel/comm.hpp"

int main(int argc, char** argv) {
  capsflow::parallel::MpiSession session(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (!capsflow::parallel::Comm::world().is_root()) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int failed = RUN_ALL_TESTS();
  return failed;
}
