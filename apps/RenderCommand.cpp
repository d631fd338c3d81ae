#include "RenderCommand.hpp"

#include "comm/BinarySwap.hpp"
#include "core/Error.hpp"
#include "domain/Scene.hpp"
#include "io/SnapshotReader.hpp"
#include "kernels/exec/Backend.hpp"
#include "render/DepthComposite.hpp"
#include "render/FrameSelection.hpp"
#include "render/SnapshotRender.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <regex>
#include <vector>

namespace kf {

namespace fs = std::filesystem;

namespace {

/// The run's snapshots by frame index (frame_NNNNNN.h5).
std::vector<std::pair<std::uint64_t, fs::path>> snapshots(const std::string& dir) {
  if (!fs::is_directory(dir))
    throw InputError(dir + ": not a directory (knitflow render takes a run's output directory)");
  static const std::regex name(R"(^frame_(\d+)\.h5$)");
  std::vector<std::pair<std::uint64_t, fs::path>> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string f = e.path().filename().string();
    if (e.is_regular_file() && std::regex_match(f, m, name))
      out.emplace_back(std::stoull(m[1]), e.path());
  }
  std::sort(out.begin(), out.end());
  if (out.empty())
    throw InputError(dir + ": no snapshots (frame_NNNNNN.h5) to render");
  return out;
}

/// The scene's sphere obstacles, grey (planes, boxes and meshes come with the later stages'
/// floor and meshes): from `scene_file` when given, else from the snapshot's copy of its scene.
/// That copy names mesh files relative to where the scene file was, which the snapshot does not
/// record: where they cannot be found, the obstacles are left out with a warning.
std::vector<render::Sphere> obstacle_spheres(const io::Frame& f, const std::string& snapshot,
                                             const std::string& scene_file, bool warn,
                                             std::ostream& log) {
  std::vector<render::Sphere> out;
  Scene scene;
  if (!scene_file.empty()) {
    scene = load_scene(scene_file);
  } else {
    if (f.scene_text.empty())
      return out;
    try {
      scene = parse_scene(f.scene_text, snapshot + " (its scene)");
    } catch (const SceneError& e) {
      if (warn)
        log << "render: warning: obstacles not drawn: " << e.what()
            << " (pass the run's scene file with --scene)\n";
      return out;
    }
  }
  for (const Obstacle& o : scene.obstacles)
    if (o.shape == ObstacleShape::Sphere)
      out.push_back(
          {glm::vec4(float(o.center.x), float(o.center.y), float(o.center.z), float(o.radius)),
           glm::vec4(0.55f, 0.57f, 0.6f, 1.0f)});
  return out;
}

/// The chosen pictures as an H.264 MP4 (out/film.mp4) through ffmpeg, in frame order, fps a
/// second; a missing ffmpeg is a message, not an error (the pictures are the product).
void make_film(const fs::path& out, const std::vector<std::uint64_t>& frames, int fps,
               std::ostream& log) {
  if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) {
    log << "render: ffmpeg not found: no film (install ffmpeg for " << (out / "film.mp4").string()
        << ")\n";
    return;
  }
  // The concat list names exactly the chosen pictures (a glob would take earlier renders' too).
  const fs::path list = out / "film.ffconcat";
  {
    std::ofstream f(list);
    f << "ffconcat version 1.0\n";
    for (std::uint64_t k : frames) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06llu.png", static_cast<unsigned long long>(k));
      f << "file '" << name << "'\nduration " << 1.0 / fps << "\n";
    }
  }
  const fs::path film = out / "film.mp4";
  // Even sizes for 4:2:0 chroma; the last picture held for one frame (concat's duration).
  const std::string cmd = "ffmpeg -y -loglevel error -f concat -safe 0 -i '" + list.string() +
                          "' -vf 'fps=" + std::to_string(fps) +
                          ",scale=trunc(iw/2)*2:trunc(ih/2)*2,format=yuv420p' -c:v libx264 '" +
                          film.string() + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  fs::remove(list);
  if (rc != 0)
    throw Error("render: ffmpeg failed (exit status " + std::to_string(rc) + ") making " +
                film.string() + ": " + cmd);
  log << "render: film " << film.string() << " (" << frames.size() << " frames, " << fps
      << " a second)\n";
}

} // namespace

int render_run(const RenderArgs& a, const comm::MpiContext& mpi, std::ostream& log) {
  const auto all = snapshots(a.run_dir);
  std::vector<std::uint64_t> indices;
  for (const auto& s : all)
    indices.push_back(s.first);
  const auto chosen = render::select_frames(a.frames, indices);
  if (chosen.empty())
    throw InputError("--frames '" + a.frames + "' selects none of the " +
                     std::to_string(all.size()) + " snapshots in " + a.run_dir);
  auto path_of = [&](std::uint64_t index) {
    return std::find_if(all.begin(), all.end(), [&](const auto& s) { return s.first == index; })
        ->second;
  };
  const fs::path out = a.out.empty() ? fs::path(a.run_dir) / "render" : fs::path(a.out);
  fs::create_directories(out);
  // One camera for the film: every rank frames the first chosen snapshot the same way.
  const io::Frame first = io::read_snapshot(MPI_COMM_SELF, path_of(chosen.front()).string());
  render::SnapshotStyle style;
  style.width = a.width;
  style.height = a.height;
  style.boundary = a.boundary;
  style.fluid_surface = a.fluid == "surface";
  style.obstacles = obstacle_spheres(first, path_of(chosen.front()).string(), a.scene,
                                     mpi.root() && !a.quiet, log);
  // On a GPU the EGL device of this rank's CUDA device (as `run` chooses it); else llvmpipe.
  const int cuda_device = exec::cuda_available() ? exec::cuda_select_device(mpi.local_rank()) : -1;
  render::SnapshotRenderer renderer(style, cuda_device);
  const render::Camera camera = renderer.frame_camera(first);
  if (mpi.root() && !a.quiet)
    log << "render: " << chosen.size() << " frame(s) of " << a.run_dir << " on " << mpi.size()
        << " rank(s), " << a.width << " x " << a.height << ", " << renderer.context().renderer
        << "\n";
  int written = 0;
  const bool by_space =
      mpi.size() > 1 &&
      (a.split == "space" || (a.split == "auto" && chosen.size() < std::size_t(mpi.size())));
  if (by_space) {
    if (mpi.root() && !a.quiet)
      log << "render: each frame in " << mpi.size()
          << " parts (a k-d split of its particles), composited by depth (binary swap)\n";
    for (std::size_t k = 0; k < chosen.size(); ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      const io::Frame f =
          k == 0 ? first : io::read_snapshot(MPI_COMM_SELF, path_of(chosen[k]).string());
      const auto regions = render::kd_split(renderer.drawn_points(f), mpi.size());
      const io::RgbaImage part = renderer.draw(f, camera, &regions[std::size_t(mpi.rank())]);
      auto px = render::depth_pixels(part, renderer.depth());
      const auto t1 = std::chrono::steady_clock::now();
      const auto swap = comm::binary_swap(
          mpi.comm(), px.data(), px.size(), sizeof(render::DepthPixel),
          [](void* mine, const void* theirs, std::size_t n) {
            render::keep_nearer(static_cast<render::DepthPixel*>(mine),
                                static_cast<const render::DepthPixel*>(theirs), n);
          });
      const auto t2 = std::chrono::steady_clock::now();
      const std::uint64_t spheres = mpi.sum(std::uint64_t(renderer.last_spheres()));
      const std::uint64_t triangles = mpi.sum(std::uint64_t(renderer.last_triangles()));
      if (mpi.root()) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%06llu.png",
                      static_cast<unsigned long long>(chosen[k]));
        io::write_png((out / name).string(), render::colour_of(px, a.width, a.height));
        ++written;
        using sec = std::chrono::duration<double>;
        if (!a.quiet)
          log << "render: " << (out / name).string() << " (t = " << f.time << " s): " << spheres
              << " spheres, " << triangles << " triangles, "
              << sec(std::chrono::steady_clock::now() - t0).count() << " s (draw "
              << sec(t1 - t0).count() << " s, composite " << sec(t2 - t1).count() << " s, "
              << swap.bytes_sent << " bytes sent by rank 0)\n";
      }
    }
  }
  for (std::size_t k = std::size_t(mpi.rank()); !by_space && k < chosen.size();
       k += std::size_t(mpi.size())) {
    const auto t0 = std::chrono::steady_clock::now();
    const fs::path src = path_of(chosen[k]);
    const io::Frame f = k == 0 ? first : io::read_snapshot(MPI_COMM_SELF, src.string());
    const auto t1 = std::chrono::steady_clock::now();
    const io::RgbaImage img = renderer.draw(f, camera);
    const auto t2 = std::chrono::steady_clock::now();
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06llu.png",
                  static_cast<unsigned long long>(chosen[k]));
    io::write_png((out / name).string(), img);
    ++written;
    using sec = std::chrono::duration<double>;
    const auto t3 = std::chrono::steady_clock::now();
    if (mpi.root() && !a.quiet)
      log << "render: " << (out / name).string() << " (t = " << f.time
          << " s): " << renderer.last_spheres() << " spheres, " << renderer.last_triangles()
          << " triangles, " << sec(t3 - t0).count() << " s (read " << sec(t1 - t0).count()
          << ", surface " << renderer.last_surface_seconds() << ", draw and read back "
          << sec(t2 - t1).count() - renderer.last_surface_seconds() << ", PNG "
          << sec(t3 - t2).count() << ")\n";
  }
  int total = written;
  MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPI_INT, MPI_SUM, mpi.comm());
  if (mpi.root() && !a.quiet)
    log << "render: " << total << " picture(s) in " << out.string() << "\n";
  if (mpi.root() && a.film && chosen.size() > 1)
    make_film(out, chosen, a.fps, log);
  return written;
}

} // namespace kf
