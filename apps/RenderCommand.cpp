#include "RenderCommand.hpp"
#include "core/Error.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/Scene.hpp"
#include "io/SnapshotReader.hpp"
#include "kernels/exec/Backend.hpp"
#include "render/FrameParts.hpp"
#include "render/FrameSelection.hpp"
#include "render/SnapshotRender.hpp"
#include "render/SolidMeshes.hpp"
#include "render/SortLastFrame.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <optional>
#include <ostream>
#include <regex>
#include <type_traits>
#include <unistd.h>
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

/// The run's scene: `scene_file` when given, else the snapshot's copy of its scene. That copy
/// names mesh files relative to where the scene file was, which the snapshot does not record:
/// where they cannot be found, the scene is not used (a warning; obstacles and [render] left out).
std::optional<Scene> run_scene(const io::Frame& f, const std::string& snapshot,
                               const std::string& scene_file,
                               const std::vector<std::string>& overrides, bool warn,
                               std::ostream& log) {
  if (!scene_file.empty())
    return load_scene(scene_file, overrides);
  if (f.scene_text.empty()) {
    if (!overrides.empty())
      throw InputError(snapshot + ": --set " + overrides.front() +
                       ": the snapshot holds no scene to set it in (pass the run's scene with "
                       "--scene)");
    return std::nullopt;
  }
  // Its files (OBJ meshes) where the run found them; an older snapshot's: beside it.
  const std::string dir =
      f.scene_dir.empty() ? fs::path(snapshot).parent_path().string() : f.scene_dir;
  try {
    return parse_scene(f.scene_text, snapshot + " (its scene)", overrides, dir);
  } catch (const SceneError& e) {
    if (!overrides.empty()) { // the scene reads without them: a --set is at fault, not the scene
      bool plain = true;
      try {
        (void)parse_scene(f.scene_text, snapshot + " (its scene)", {}, dir);
      } catch (const SceneError&) {
        plain = false;
      }
      if (plain)
        throw;
    }
    if (warn)
      log << "render: warning: the snapshot's scene not used (no obstacles, no [render]): "
          << e.what() << " (pass the run's scene file with --scene)\n";
    return std::nullopt;
  }
}

glm::dvec3 dvec(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

/// The scene's sphere obstacles, grey, where they start, and their velocities (planes, boxes
/// and meshes come with the floor and meshes).
std::vector<render::Sphere> obstacle_spheres(const std::optional<Scene>& scene,
                                             std::vector<glm::vec3>& velocity) {
  std::vector<render::Sphere> out;
  velocity.clear();
  if (!scene)
    return out;
  for (const Obstacle& o : scene->obstacles)
    if (o.shape == ObstacleShape::Sphere) {
      out.push_back(
          {glm::vec4(float(o.center.x), float(o.center.y), float(o.center.z), float(o.radius)),
           glm::vec4(0.55f, 0.57f, 0.6f, 1.0f)});
      velocity.emplace_back(glm::vec3(dvec(o.velocity)));
    }
  return out;
}

/// The scene's boxes and OBJ meshes (solids) and its planes as meshes, where they stand at the
/// start, and a velocity a vertex (its obstacle's: the picture moves it with the frame's time).
/// A plane lying on the floor's height, facing up, is the floor's to draw.
void obstacle_meshes(const std::optional<Scene>& scene, render::SurfaceMesh& solids,
                     render::SurfaceMesh& planes, std::vector<glm::vec3>& solid_velocity,
                     std::vector<glm::vec3>& plane_velocity) {
  if (!scene)
    return;
  // Each obstacle's vertices take its velocity, appended as the meshes grow.
  auto moving = [](render::SurfaceMesh& m, std::vector<glm::vec3>& v, const Obstacle& o,
                   const render::SurfaceMesh& part) {
    render::append(m, part);
    v.resize(m.position.size(), glm::vec3(dvec(o.velocity)));
  };
  const glm::dvec3 lo = dvec(scene->domain.min), hi = dvec(scene->domain.max);
  const double reach = glm::length(hi - lo);
  for (const Obstacle& o : scene->obstacles)
    switch (o.shape) {
    case ObstacleShape::Box:
      moving(solids, solid_velocity, o, render::box_mesh(dvec(o.min), dvec(o.max)));
      break;
    case ObstacleShape::Mesh:
      if (o.mesh) {
        std::vector<glm::dvec3> v;
        for (const Vec3d& x : o.mesh->solid.vertices)
          v.push_back(dvec(x));
        moving(solids, solid_velocity, o, render::triangle_mesh(v, o.mesh->solid.triangles));
      }
      break;
    case ObstacleShape::Plane:
      if (scene->render.floor && o.normal.z > 0.999 &&
          std::abs(o.point.z - scene->domain.min.z) <= 1e-9 * (1 + reach))
        break;
      moving(planes, plane_velocity, o,
             render::plane_in_box(dvec(o.point), dvec(o.normal), lo, hi));
      break;
    case ObstacleShape::Sphere:
      break; // obstacle_spheres
    }
}

/// The tank: the domain's walls that hold the fluid, but the floor's (drawn as the floor) and
/// a lid's (from above it would turn its back to the camera anyway).
render::SurfaceMesh tank_walls(const std::optional<Scene>& scene) {
  if (!scene || !scene->render.tank || !scene->has(Module::Fluid))
    return {};
  std::array<bool, 6> sides = scene->domain.walls;
  sides[4] = sides[4] && !scene->render.floor;
  sides[5] = false;
  return render::box_inside(dvec(scene->domain.min), dvec(scene->domain.max), sides);
}

glm::vec3 vec(const Vec3d& v) {
  return {float(v.x), float(v.y), float(v.z)};
}

/// The style from the scene's [render] table (defaults without one), the command line over it.
render::SnapshotStyle style_of(const Scene::Render& r, const RenderArgs& a) {
  render::SnapshotStyle st;
  st.width = a.width > 0 ? a.width : r.width;
  st.height = a.height > 0 ? a.height : r.height;
  st.boundary = a.boundary || r.boundary;
  st.fluid_surface =
      a.fluid.empty() ? r.fluid == Scene::Render::Fluid::Surface : a.fluid == "surface";
  st.surface_field = r.surface == Scene::Render::SurfaceField::Naive
                         ? render::SurfaceField::Naive
                         : render::SurfaceField::Weighted;
  st.surface_cell = r.surface_cell;
  st.knit_yarns = a.knit.empty() ? r.knit == Scene::Render::Knit::Yarns : a.knit == "yarns";
  st.yarn_radius = r.yarn_radius;
  st.knit_volume = r.yarn_volume;
  st.lumislice.plies = r.yarn_plies;
  st.lumislice.fuzz = r.yarn_fuzz;
  st.yarn_slices = r.yarn_slices;
  st.yarn_detail_pixels = r.yarn_detail_pixels;
  st.shadows = r.shadows;
  st.floor = r.floor;
  st.fluid_reflection = r.reflections;
  st.environment_size = r.environment_map;
  st.fluid_translucent = r.refraction;
  st.refractive_index = float(r.refractive_index);
  st.absorption_depth = r.absorption_depth;
  st.geometry_on_gpu = r.gpu_geometry;
  st.wet_darkening = r.wet_darkening;
  st.fluid = glm::vec4(vec(r.fluid_colour), 1.0f);
  st.knit = glm::vec4(vec(r.knit_colour), 1.0f);
  st.background = glm::vec4(vec(r.background), 1.0f);
  st.lighting.toward_light = vec(r.light);
  st.lighting.ambient = float(r.ambient);
  st.lighting.specular = float(r.highlights);
  return st;
}

/// PNG files written on a thread of their own while the next frame is drawn (a 1080p PNG is
/// 0.15-0.35 s of zlib, P6's timing): one in flight; put() waits for the last and passes on its
/// error, finish() waits for the last.
class PngWriter {
public:
  ~PngWriter() {
    for (auto& f : pending_)
      if (f.valid())
        f.wait(); // an error here is lost only when another is already on its way out
  }
  /// Starts writing `image` on a thread of its own, at most kInFlight at once (a frame is drawn
  /// faster than one thread compresses it); returns the seconds spent waiting for the oldest.
  double put(std::string path, io::RgbaImage image) {
    const auto t0 = std::chrono::steady_clock::now();
    if (pending_.size() == kInFlight) {
      pending_.front().get();
      pending_.pop_front();
    }
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    pending_.push_back(
        std::async(std::launch::async, [p = std::move(path), img = std::move(image)] {
          io::write_png(p, img, kCompression);
        }));
    return waited;
  }
  /// Waits for every write (an error of one is thrown here).
  double finish() {
    const auto t0 = std::chrono::steady_clock::now();
    while (!pending_.empty()) {
      auto f = std::move(pending_.front());
      pending_.pop_front();
      f.get();
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

private:
  static constexpr std::size_t kInFlight = 4;
  static constexpr int kCompression = 1; // zlib's fastest: frames are many and pass to a film
  std::deque<std::future<void>> pending_;
};

/// A pass's error names the snapshot it was drawing ("FILE: render: ...").
template <typename F>
auto named(const fs::path& snapshot, F&& draw) {
  try {
    return draw();
  } catch (const InputError&) {
    throw;
  } catch (const Error& e) {
    throw Error(snapshot.string() + ": " + e.what());
  }
}

/// Where the log is a terminal, one line redrawn over the frames: a bar, frames done, the time a
/// frame and what is left; elsewhere (a job's log) a line a frame says the same.
class FrameProgress {
public:
  FrameProgress(std::ostream& log, std::size_t total, bool on)
      : log_(log), total_(total), on_(on),
        tty_(&log == &std::cerr ? isatty(2) : (&log == &std::cout ? isatty(1) : false)) {}
  bool tty() const { return tty_; }
  /// After a frame: `done` of the total, `seconds` for this one.
  void frame(std::size_t done, double seconds) {
    sum_ += seconds;
    ++seen_;
    if (!on_ || !tty_)
      return;
    const std::size_t width = 30, filled = total_ ? width * done / total_ : width;
    const double each = sum_ / double(seen_);
    char line[160];
    std::snprintf(line, sizeof line,
                  "\rrender: [%s%s] %zu/%zu frames, %.3g s a frame, ~%.0f s left ",
                  std::string(filled, '#').c_str(), std::string(width - filled, '-').c_str(), done,
                  total_, each, each * double(total_ - std::min(done, total_)));
    log_ << line << std::flush;
    if (done >= total_)
      log_ << "\n";
  }

private:
  std::ostream& log_;
  std::size_t total_;
  bool on_, tty_;
  double sum_ = 0;
  std::size_t seen_ = 0;
};

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
  // One camera for the film: every rank frames the first chosen snapshot the same way.
  const io::Frame first = io::read_snapshot(MPI_COMM_SELF, path_of(chosen.front()).string());
  const std::optional<Scene> scene = run_scene(first, path_of(chosen.front()).string(), a.scene,
                                               a.overrides, mpi.root() && !a.quiet, log);
  const Scene::Render look = scene ? scene->render : Scene::Render{};
  render::SnapshotStyle style = style_of(look, a);
  style.obstacles = obstacle_spheres(scene, style.obstacle_velocity);
  if (scene)
    style.floor_z = scene->domain.min.z;
  obstacle_meshes(scene, style.solids, style.planes, style.solid_velocity, style.plane_velocity);
  style.tank = tank_walls(scene);
  fs::create_directories(out); // after every check of the input: a refused call writes nothing
  // On a GPU the EGL device of this rank's CUDA device (as `run` chooses it); else llvmpipe.
  const int cuda_device = exec::cuda_available() ? exec::cuda_select_device(mpi.local_rank()) : -1;
  render::SnapshotRenderer renderer(style, cuda_device);
  // The scene's camera, or one framing the first and the last chosen frame (what spreads or
  // falls stays in the picture); turned by `orbit` degrees a simulated second about the
  // target's vertical.
  std::optional<io::Frame> last;
  if (chosen.size() > 1)
    last = named(path_of(chosen.back()),
                 [&] { return io::read_snapshot(MPI_COMM_SELF, path_of(chosen.back()).string()); });
  std::optional<std::pair<glm::dvec3, glm::dvec3>> tank;
  if (scene && scene->has(Module::Fluid)) {
    const auto& w = scene->domain.walls; // x-, x+, y-, y+: walled in on every side
    if (w[0] && w[1] && w[2] && w[3])
      tank.emplace(glm::dvec3(scene->domain.min.x, scene->domain.min.y, scene->domain.min.z),
                   glm::dvec3(scene->domain.max.x, scene->domain.max.y, scene->domain.max.z));
  }
  render::Camera base = named(path_of(chosen.front()), [&] {
    return renderer.film_camera(first, last ? *last : first, tank);
  });
  last.reset();
  if (look.camera) {
    // Near and far bracket the framed box's sphere (centre: the framing's target, radius: half
    // its far - distance) as seen from the scene's eye: a near plane too close spends the depth
    // buffer's 24 bits there, and surfaces a hair apart tie (and may composite differently).
    const double radius = 0.5 * (base.far - glm::length(base.eye - base.target));
    const glm::dvec3 centre = base.target;
    base.eye = {look.eye.x, look.eye.y, look.eye.z};
    base.target = {look.target.x, look.target.y, look.target.z};
    const double d = glm::length(base.eye - centre);
    base.near = std::max(d - 2 * radius, 1e-2 * (d + 2 * radius));
    base.far = d + 2 * radius;
  }
  if (look.camera)
    base.fov_deg = look.fov;
  const auto camera_at = [&](double t) {
    render::Camera c = base;
    const double turn = look.orbit * t * std::acos(-1.0) / 180;
    const glm::dvec3 r = c.eye - c.target;
    c.eye = c.target + glm::dvec3(r.x * std::cos(turn) - r.y * std::sin(turn),
                                  r.x * std::sin(turn) + r.y * std::cos(turn), r.z);
    return c;
  };
  if (mpi.root() && !a.quiet)
    log << "render: " << chosen.size() << " frame(s) of " << a.run_dir << " on " << mpi.size()
        << " rank(s), " << style.width << " x " << style.height << ", "
        << renderer.context().renderer << "\n";
  int written = 0;
  PngWriter png;
  FrameProgress bar(log, chosen.size(), mpi.root() && !a.quiet);
  const bool by_space =
      mpi.size() > 1 &&
      (a.split == "space" || (a.split == "auto" && chosen.size() < std::size_t(mpi.size())));
  if (by_space) {
    // Each rank draws its part's casters: the shadow maps are every rank's nearest.
    renderer.set_shadow_combiner([&mpi](std::vector<float>& d) {
      MPI_Allreduce(MPI_IN_PLACE, d.data(), int(d.size()), MPI_FLOAT, MPI_MIN, mpi.comm());
    });
    if (mpi.root() && !a.quiet)
      log << "render: each frame in " << mpi.size()
          << " parts (a k-d split of its particles), composited by depth and the yarns by \"over\" "
             "in order (binary swap)\n";
    for (std::size_t k = 0; k < chosen.size(); ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      // Each rank reads its share of the file and keeps its region's fluid (and a halo).
      const render::FramePart part = named(path_of(chosen[k]), [&] {
        return render::read_frame_part(mpi.comm(), path_of(chosen[k]).string(), renderer);
      });
      const io::Frame& f = part.frame;
      const auto t_read = std::chrono::steady_clock::now();
      // Opaque parts (and the translucent water's layers) composite by depth, the volumetric
      // yarns' layers by "over" in the regions' order from the eye; the root's picture.
      render::SortLastTimes times;
      io::RgbaImage picture = named(path_of(chosen[k]), [&] {
        return render::draw_sort_last(mpi.comm(), renderer, f, camera_at(f.time), part.regions,
                                      &times);
      });
      const std::uint64_t spheres = mpi.sum(std::uint64_t(renderer.last_spheres()));
      const std::uint64_t triangles = mpi.sum(std::uint64_t(renderer.last_triangles()));
      if (mpi.root()) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%06llu.png",
                      static_cast<unsigned long long>(chosen[k]));
        png.put((out / name).string(), std::move(picture));
        ++written;
        using sec = std::chrono::duration<double>;
        bar.frame(k + 1, sec(std::chrono::steady_clock::now() - t0).count());
        if (!a.quiet && !bar.tty())
          log << "render: " << (out / name).string() << " (t = " << f.time << " s): " << spheres
              << " spheres, " << triangles << " triangles, "
              << sec(std::chrono::steady_clock::now() - t0).count() << " s (read "
              << sec(t_read - t0).count() << " s, draw " << times.draw << " s, composite "
              << times.composite << " s, yarns " << times.yarns << " s, their composite "
              << times.yarn_composite << " s, resolve " << times.resolve << " s, "
              << times.bytes_sent << " bytes sent by rank 0; its fluid rows: " << part.fluid_read
              << " read, " << part.fluid_held << " drawn or about its part, of " << part.fluid_total
              << ")\n";
      }
    }
  }
  for (std::size_t k = std::size_t(mpi.rank()); !by_space && k < chosen.size();
       k += std::size_t(mpi.size())) {
    const auto t0 = std::chrono::steady_clock::now();
    const fs::path src = path_of(chosen[k]);
    const io::Frame f = k == 0 ? first : io::read_snapshot(MPI_COMM_SELF, src.string());
    const auto t1 = std::chrono::steady_clock::now();
    io::RgbaImage img = named(src, [&] { return renderer.draw(f, camera_at(f.time)); });
    const auto t2 = std::chrono::steady_clock::now();
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06llu.png",
                  static_cast<unsigned long long>(chosen[k]));
    const double waited = png.put((out / name).string(), std::move(img));
    ++written;
    using sec = std::chrono::duration<double>;
    const auto t3 = std::chrono::steady_clock::now();
    // The root's share of the frames stands for everyone's (the ranks go at one pace).
    bar.frame(std::min(chosen.size(), (k / std::size_t(mpi.size()) + 1) * std::size_t(mpi.size())),
              sec(t3 - t0).count());
    if (mpi.root() && !a.quiet && !bar.tty())
      log << "render: " << (out / name).string() << " (t = " << f.time
          << " s): " << renderer.last_spheres() << " spheres, " << renderer.last_triangles()
          << " triangles, " << sec(t3 - t0).count() << " s (read " << sec(t1 - t0).count()
          << ", surface " << renderer.last_surface_seconds() << ", yarns "
          << renderer.last_yarn_seconds() << ", draw and read back "
          << sec(t2 - t1).count() - renderer.last_surface_seconds() - renderer.last_yarn_seconds()
          << ", waiting for a PNG writer " << waited << "; GPU passes "
          << render::format_passes(renderer.last_passes()) << ")\n";
  }
  png.finish();
  int total = written;
  MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPI_INT, MPI_SUM, mpi.comm());
  if (mpi.root() && !a.quiet)
    log << "render: " << total << " picture(s) in " << out.string() << "\n";
  if (mpi.root() && a.film && chosen.size() > 1)
    make_film(out, chosen, a.fps, log);
  return written;
}

} // namespace kf
