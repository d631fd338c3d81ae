#pragma once
// `knitflow render RUN_DIR`: a run's snapshots to PNG pictures (P6), the work shared over the
// job's ranks: whole frames each, or each frame in parts composited sort-last (binary swap).
#include "comm/MpiContext.hpp"

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace kf {

struct RenderArgs {
  std::string run_dir;
  std::string frames = "::"; // A:B:S, frame indices A to B (inclusive) every S
  std::string out;           // default RUN_DIR/render
  int width = 0, height = 0; // 0: the scene's [render] size (1280 x 720 without one)
  std::string scene; // obstacles and [render] from this scene file, not the snapshot's own text
  bool boundary = false;
  bool film = true; // an MP4 of the pictures through ffmpeg, where it is installed
  int fps = 25;
  bool quiet = false;
  // How ranks share the work: "frames" (whole frames each), "space" (every frame drawn in parts
  // of a k-d split, composited by depth), "auto" (space when there are fewer frames than ranks).
  std::string split = "auto";
  std::string fluid; // "surface" or "spheres" (the particles); empty: the scene's [render] choice
  std::string knit;  // "yarns" or "points"; empty: the scene's [render] choice
  // Keys of the scene over its file's or the snapshot's copy ("render.eye=[0.1, -0.2, 0.6]").
  std::vector<std::string> overrides;
};

/// Renders and writes the pictures, then (rank 0) the film of them when there are two or more;
/// returns how many pictures this rank wrote.
int render_run(const RenderArgs& a, const comm::MpiContext& mpi, std::ostream& log);

} // namespace kf
