// gtest main for every knitflow test: initialises MPI (snapshots are written through MPI-IO even
// on one rank), gives each rank its GPU as knitflow does (local rank % devices; a no-op without
// CUDA) and lets only rank 0 print, so mpiexec -n 2 output stays readable.
#include "comm/MpiContext.hpp"
#include "kernels/exec/Backend.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <mpi.h>
#include <string>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  {
    const kf::comm::MpiContext mpi;
    kf::exec::cuda_select_device(mpi.local_rank());
  }
  // KF_TEST_ALL_RANKS=1: every rank prints (a failure seen on one rank only).
  const char* every = std::getenv("KF_TEST_ALL_RANKS");
  if (rank != 0 && !(every && std::string(every) == "1")) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  int rc = RUN_ALL_TESTS();
  // A failure on any rank fails the run.
  int any = rc != 0;
  int all = 0;
  MPI_Allreduce(&any, &all, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return all;
}
