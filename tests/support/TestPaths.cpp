#include "TestPaths.hpp"

#include <mpi.h>

#include <cstdlib>

namespace kf::test {

std::filesystem::path source_dir() {
  return KF_SOURCE_DIR;
}
std::filesystem::path data_dir() {
  return KF_TEST_DATA_DIR;
}
std::filesystem::path knitflow_exe() {
  // KF_KNITFLOW: a packed binary on a machine without the build tree (jobs/gpu/gpu_tests.sh).
  if (const char* e = std::getenv("KF_KNITFLOW"); e && *e)
    return e;
  return KF_KNITFLOW_EXE;
}

std::filesystem::path scratch_dir(const std::string& name) {
  int rank = 0, init = 0;
  MPI_Initialized(&init);
  if (init)
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  auto p = std::filesystem::path(KF_BINARY_DIR) / "test-scratch" / name;
  if (rank == 0) {
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
  }
  if (init)
    MPI_Barrier(MPI_COMM_WORLD);
  return p;
}

} // namespace kf::test
