// main of the MPI tests: MPI_Init, the MPI collective as maskadapt::world(), GoogleTest on every
// rank. The job fails when a test fails on any rank. Run under `mpirun -np 2` (tests/mpi/CMakeLists.txt).
#include <maskadapt/mpi/collective.hpp>

#include <gtest/gtest.h>

int main(int argc, char** argv) {
  maskadapt::mpi::Session session(&argc, &argv, /*enable=*/true);
  ::testing::InitGoogleTest(&argc, argv);
  int failed = 0;
  {
    maskadapt::mpi::MpiCollective world;
    maskadapt::world_slot() = &world;
    failed = RUN_ALL_TESTS() != 0 ? 1 : 0;
    const double any = maskadapt::all_reduce_sum(world, static_cast<double>(failed));
    maskadapt::world_slot() = &maskadapt::single_process();
    failed = any > 0 ? 1 : 0;
  }
  return failed;
}
