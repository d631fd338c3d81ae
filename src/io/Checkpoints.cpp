#include "io/Checkpoints.hpp"

#include "core/Error.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <vector>

namespace kf::io {

namespace fs = std::filesystem;

std::string checkpoint_file_name(std::uint64_t step) {
  char name[48];
  std::snprintf(name, sizeof name, "checkpoint_%012llu.h5", static_cast<unsigned long long>(step));
  return name;
}

namespace {

/// The files in dir whose names match, sorted by name (zero-padded: by step or index).
std::vector<fs::path> matching(const std::string& dir, const std::regex& pattern) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return out;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (std::regex_match(e.path().filename().string(), pattern))
      out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

const std::regex& checkpoint_pattern() {
  static const std::regex p(R"(checkpoint_\d+\.h5)");
  return p;
}

int rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

} // namespace

CheckpointWriter::CheckpointWriter(MPI_Comm comm, std::string dir, int keep)
    : comm_(comm), dir_(std::move(dir)), keep_(std::max(1, keep)) {
  int failed = 0;
  std::string why;
  if (rank_of(comm_) == 0) {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) {
      failed = 1;
      why = dir_ + ": cannot create the checkpoint directory (" + ec.message() + ")";
    } else {
      for (const auto& p : matching(dir_, std::regex(R"(checkpoint_\d+\.h5\.tmp)")))
        fs::remove(p, ec); // a write a killed job left unfinished
    }
  }
  MPI_Bcast(&failed, 1, MPI_INT, 0, comm_);
  if (failed)
    throw Error(rank_of(comm_) == 0 ? why : dir_ + ": cannot create the checkpoint directory");
}

std::string CheckpointWriter::write(const Frame& f, std::uint64_t step) {
  const std::string path = publish_snapshot(comm_, dir_ + "/" + checkpoint_file_name(step), f);
  if (rank_of(comm_) == 0) {
    const auto all = matching(dir_, checkpoint_pattern());
    std::error_code ec;
    for (std::size_t i = 0; i + std::size_t(keep_) < all.size(); ++i)
      fs::remove(all[i], ec); // the oldest; a failure leaves one more, harmlessly
  }
  return path;
}

std::string latest_state(const std::string& output_dir) {
  std::string best;
  double best_time = -1;
  bool best_is_checkpoint = false;
  auto consider = [&](const fs::path& p, bool checkpoint) {
    try {
      const SnapshotInfo info = read_snapshot_info(p.string());
      if (info.time > best_time || (info.time == best_time && checkpoint && !best_is_checkpoint)) {
        best = p.string();
        best_time = info.time;
        best_is_checkpoint = checkpoint;
      }
    } catch (const Error&) { // unreadable: not a state to continue from
    }
  };
  for (const auto& p : matching(output_dir + "/checkpoints", checkpoint_pattern()))
    consider(p, true);
  for (const auto& p : matching(output_dir, std::regex(R"(frame_\d+\.h5)")))
    consider(p, false);
  if (best.empty())
    throw InputError("--restart latest: no complete checkpoint or snapshot in " + output_dir +
                     " (nor in " + output_dir + "/checkpoints)");
  return best;
}

} // namespace kf::io
