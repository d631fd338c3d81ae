#include "render/SnapshotRender.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>

namespace kf::render {

std::vector<std::size_t> spacing_samples(std::size_t n) {
  const std::size_t samples = std::min<std::size_t>(256, n);
  std::vector<std::size_t> at(samples);
  for (std::size_t s = 0; s < samples; ++s)
    at[s] = s * n / samples;
  return at;
}

void nearest_to_samples(const std::vector<glm::dvec3>& sample,
                        const std::vector<std::size_t>& sample_index,
                        const std::vector<glm::dvec3>& points, std::size_t first,
                        std::vector<double>& best) {
  for (std::size_t s = 0; s < sample.size(); ++s)
    for (std::size_t j = 0; j < points.size(); ++j)
      if (first + j != sample_index[s]) {
        const glm::dvec3 d = points[j] - sample[s];
        const double d2 = glm::dot(d, d);
        if (d2 > 0)
          best[s] = std::min(best[s], d2);
      }
}

double median_spacing(const std::vector<double>& best) {
  std::vector<double> nearest;
  for (double b : best)
    if (std::isfinite(b))
      nearest.push_back(std::sqrt(b));
  if (nearest.empty())
    return 0;
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  return nearest[nearest.size() / 2];
}

double typical_spacing(const std::vector<glm::dvec3>& points) {
  if (points.size() < 2)
    return 0;
  const std::vector<std::size_t> at = spacing_samples(points.size());
  std::vector<glm::dvec3> sample;
  for (std::size_t i : at)
    sample.push_back(points[i]);
  std::vector<double> best(at.size(), std::numeric_limits<double>::infinity());
  nearest_to_samples(sample, at, points, 0, best);
  return median_spacing(best);
}

namespace {

/// A phase's position field (3 components, float or double): null without the phase, a
/// kf::Error naming it when the phase has no such field.
const io::Field* position_field(const io::Frame& frame, const std::string& phase) {
  const io::Phase* p = frame.find(phase);
  if (!p)
    return nullptr;
  const io::Field* f = p->find("position");
  if (!f || f->components != 3)
    throw Error("render: the snapshot's " + phase + " phase has no 3-component position field");
  if (f->type != io::DType::F32 && f->type != io::DType::F64)
    throw Error("render: the snapshot's " + phase + " positions are not floating point");
  return f;
}

/// Component k of row i of a float or double field, read where it is stored (no copy of the
/// field: a garment's yarns are half a million points a frame).
double stored(const io::Field& f, std::size_t i, int k) {
  const std::size_t at = std::size_t(f.components) * i + std::size_t(k);
  if (f.type == io::DType::F32) {
    float v;
    std::memcpy(&v, f.bytes.data() + at * sizeof v, sizeof v);
    return v;
  }
  double v;
  std::memcpy(&v, f.bytes.data() + at * sizeof v, sizeof v);
  return v;
}

glm::dvec3 stored_point(const io::Field& f, std::size_t i) {
  return {stored(f, i, 0), stored(f, i, 1), stored(f, i, 2)};
}

} // namespace

std::vector<glm::dvec3> phase_positions(const io::Frame& frame, const std::string& phase) {
  const io::Field* f = position_field(frame, phase);
  if (!f)
    return {};
  std::vector<glm::dvec3> out(f->count);
  const auto n = std::ptrdiff_t(f->count);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i)
    out[std::size_t(i)] = stored_point(*f, std::size_t(i));
  return out;
}

namespace {

/// A per-particle scalar field as doubles (float or double stored), or empty.
std::vector<double> scalar_field(const io::Frame& frame, const std::string& phase,
                                 const std::string& name) {
  const io::Phase* p = frame.find(phase);
  const io::Field* f = p ? p->find(name) : nullptr;
  if (!f || f->components != 1)
    return {};
  if (f->type == io::DType::F32) {
    const auto v = f->as<float>();
    return {v.begin(), v.end()};
  }
  if (f->type == io::DType::F64)
    return f->as<double>();
  auto widen = [](const auto& v) { return std::vector<double>(v.begin(), v.end()); };
  if (f->type == io::DType::U32)
    return widen(f->as<std::uint32_t>());
  if (f->type == io::DType::I32)
    return widen(f->as<std::int32_t>());
  if (f->type == io::DType::U64)
    return widen(f->as<std::uint64_t>());
  return {};
}

/// The typical spacing of a phase's points in one layer (the knit's three layers lie closer than
/// its points in a layer: the first point's layer), of all of them without a layer field;
/// nothing without the phase.
std::optional<double> layer_spacing(const io::Frame& frame, const std::string& phase) {
  const auto x = phase_positions(frame, phase);
  if (x.empty())
    return std::nullopt;
  const auto layer = scalar_field(frame, phase, "layer");
  std::vector<glm::dvec3> one;
  for (std::size_t i = 0; i < layer.size() && i < x.size(); ++i)
    if (layer[i] == layer[0])
      one.push_back(x[i]);
  return typical_spacing(one.size() > 1 ? one : x);
}

/// A phase's "segment" field (pairs of point indices), or a kf::Error naming what is missing.
std::vector<std::array<std::uint32_t, 2>> segments(const io::Frame& frame,
                                                   const std::string& phase) {
  const io::Phase* p = frame.find(phase);
  const io::Field* f = p ? p->find("segment") : nullptr;
  if (!f || f->components != 2 || f->type != io::DType::U32)
    throw Error("render: the snapshot's " + phase +
                " phase has no segment field (2 unsigned 32-bit indices a point)");
  std::vector<std::array<std::uint32_t, 2>> out(f->count);
  static_assert(sizeof(out[0]) == 2 * sizeof(std::uint32_t));
  if (f->bytes.size() != f->count * sizeof(out[0]))
    throw Error("render: the snapshot's " + phase + " segment field holds " +
                std::to_string(f->bytes.size()) + " bytes for " + std::to_string(f->count) +
                " points");
  if (!out.empty())
    std::memcpy(out.data(), f->bytes.data(), f->bytes.size()); // the same layout: pairs in a row
  return out;
}

/// The yarn phase for the GPU's tubes, read straight from the stored bytes (one pass a field,
/// in parallel: half a million points a frame).
YarnPoints yarn_points_of(const io::Frame& frame) {
  const io::Field* x = position_field(frame, "yarn");
  if (!x)
    throw Error("render: the snapshot has no yarn phase");
  YarnPoints y;
  y.segment = segments(frame, "yarn");
  const std::size_t n = x->count;
  y.point.resize(n);
  const io::Field* s = frame.find("yarn")->find("saturation");
  if (s && (s->components != 1 || s->count != n ||
            (s->type != io::DType::F32 && s->type != io::DType::F64)))
    s = nullptr; // as scalar_field: a saturation not of this shape is none
  const auto count = std::ptrdiff_t(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < count; ++j) {
    const auto i = std::size_t(j);
    y.point[i] = glm::vec4(glm::vec3(stored_point(*x, i)), s ? float(stored(*s, i, 0)) : 0.0f);
  }
  // Stitch colours (a colour chart): rgb a point, negative where its piece has none.
  const io::Field* c = frame.find("yarn")->find("colour");
  if (c && c->components == 3 && c->count == n &&
      (c->type == io::DType::F32 || c->type == io::DType::F64)) {
    y.colour.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const glm::vec3 rgb(stored(*c, i, 0), stored(*c, i, 1), stored(*c, i, 2));
      y.colour[i] = rgb.r >= 0 ? glm::vec4(rgb, 1.0f) : glm::vec4(0.0f);
    }
  }
  return y;
}

} // namespace

SnapshotRenderer::SnapshotRenderer(const SnapshotStyle& style, int cuda_device)
    : style_(style), context_(cuda_device), target_(style.width, style.height),
      sort_on_cuda_(cuda_device >= 0 && !context_.info().software) {}

namespace {

/// Grows [lo, hi] by a phase's positions, read where they lie.
void grow_by_phase(const io::Frame& frame, const std::string& phase, glm::dvec3& lo,
                   glm::dvec3& hi) {
  const io::Field* f = position_field(frame, phase);
  if (!f)
    return;
  for (std::size_t i = 0; i < f->count; ++i) {
    const glm::dvec3 x = stored_point(*f, i);
    lo = glm::min(lo, x);
    hi = glm::max(hi, x);
  }
}

} // namespace

SnapshotRenderer::Placed SnapshotRenderer::placed(double time) const {
  auto check = [](std::size_t velocities, std::size_t things, const char* what) {
    if (velocities != 0 && velocities != things)
      throw Error(std::string("render: ") + std::to_string(velocities) + " velocities for " +
                  std::to_string(things) + " " + what);
  };
  check(style_.obstacle_velocity.size(), style_.obstacles.size(), "obstacle spheres");
  check(style_.solid_velocity.size(), style_.solids.position.size(), "solids' vertices");
  check(style_.plane_velocity.size(), style_.planes.position.size(), "planes' vertices");
  Placed p{style_.obstacles, style_.solids, style_.planes};
  const float t = float(time);
  for (std::size_t i = 0; i < style_.obstacle_velocity.size(); ++i)
    p.spheres[i].centre_radius += glm::vec4(t * style_.obstacle_velocity[i], 0.0f);
  for (std::size_t i = 0; i < style_.solid_velocity.size(); ++i)
    p.solids.position[i] += t * style_.solid_velocity[i];
  for (std::size_t i = 0; i < style_.plane_velocity.size(); ++i)
    p.planes.position[i] += t * style_.plane_velocity[i];
  return p;
}

std::pair<glm::dvec3, glm::dvec3> SnapshotRenderer::frame_box(const io::Frame& frame) const {
  return box_of(frame, placed(frame.time));
}

std::pair<glm::dvec3, glm::dvec3> SnapshotRenderer::box_of(const io::Frame& frame,
                                                           const Placed& at) const {
  const auto box = content_box(frame, at);
  if (!box)
    throw Error("render: the snapshot holds nothing to draw (no fluid, knit or obstacle)");
  return *box;
}

std::optional<std::pair<glm::dvec3, glm::dvec3>>
SnapshotRenderer::content_box(const io::Frame& frame, const Placed& at) const {
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  auto grow = [&](const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  };
  for (const char* phase : {"fluid", "knit", "yarn"})
    if (std::string(phase) != "fluid" || !whole_fluid_)
      grow_by_phase(frame, phase, lo, hi);
  if (whole_fluid_ && !whole_fluid_->empty) {
    grow(whole_fluid_->lo);
    grow(whole_fluid_->hi);
  }
  if (style_.boundary)
    grow_by_phase(frame, "boundary", lo, hi);
  for (const Sphere& s : at.spheres) {
    const glm::dvec3 c(s.centre_radius), r(s.centre_radius.w);
    grow(c - r);
    grow(c + r);
  }
  for (const glm::vec3& v : at.solids.position) // (planes reach past the frame: not framed)
    grow(glm::dvec3(v));
  if (!(lo.x <= hi.x))
    return std::nullopt;
  return std::pair{lo, hi};
}

Camera SnapshotRenderer::frame_camera(const io::Frame& frame) const {
  const auto [lo, hi] = frame_box(frame);
  return Camera::framing(lo, hi, double(style_.width) / style_.height);
}

Camera SnapshotRenderer::film_camera(const io::Frame& first, const io::Frame& last,
                                     const std::optional<std::pair<glm::dvec3, glm::dvec3>>& tank) {
  stage_ = frame_box(first);
  if (tank)
    stage_.emplace(glm::min(stage_->first, tank->first), glm::max(stage_->second, tank->second));
  // A last frame with nothing left to draw (the fluid gone through an open side) adds nothing.
  if (const auto box = content_box(last, placed(last.time)))
    stage_.emplace(glm::min(stage_->first, box->first), glm::max(stage_->second, box->second));
  return Camera::framing(stage_->first, stage_->second, double(style_.width) / style_.height);
}

namespace {

/// A square at height z under the box, three times its largest extent a side, facing up.
SurfaceMesh floor_square(const glm::dvec3& lo, const glm::dvec3& hi, double z) {
  const glm::dvec3 c = 0.5 * (lo + hi);
  const double h = 1.5 * std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-6});
  SurfaceMesh m;
  for (int k = 0; k < 4; ++k) {
    m.position.emplace_back(float(c.x + (k & 1 ? h : -h)), float(c.y + (k & 2 ? h : -h)), float(z));
    m.normal.emplace_back(0.0f, 0.0f, 1.0f);
  }
  m.index = {0, 1, 3, 0, 3, 2};
  return m;
}

} // namespace

SurfaceOptions SnapshotRenderer::surface_options() const {
  SurfaceOptions opt;
  opt.field = style_.surface_field;
  opt.cell = style_.surface_cell;
  opt.spacing = fluid_r_ ? 2 * *fluid_r_ : 0;
  return opt;
}

void SnapshotRenderer::set_whole_fluid(std::optional<WholeFluid> whole) {
  whole_fluid_ = whole;
  if (whole && whole->spacing > 0 && !fluid_r_) // the first frame's, kept (as drawn whole)
    fluid_r_ = 0.5 * whole->spacing;
}

double SnapshotRenderer::fluid_halo(const WholeFluid& whole) const {
  const double spacing = fluid_r_ ? 2 * *fluid_r_ : whole.spacing;
  if (!style_.fluid_surface || whole.empty || !(spacing > 0))
    return 0;
  // The grid surface_field lays over the whole fluid (its cell, maybe coarsened): a part fills
  // the vertices within 2 cells of its region, each from the points within the kernel's reach;
  // a spacing more against rounding.
  SurfaceOptions opt = surface_options();
  opt.spacing = spacing;
  opt.box = std::pair(whole.lo, whole.hi);
  const ScalarGrid g = surface_grid({whole.lo}, opt);
  return opt.support * opt.spacing + 2 * g.cell + opt.spacing;
}

std::vector<glm::dvec3> SnapshotRenderer::drawn_points(const io::Frame& frame,
                                                       bool with_fluid) const {
  std::vector<glm::dvec3> all;
  for (const char* phase : {"fluid", "knit", "boundary"}) {
    if ((std::string(phase) == "boundary" && !style_.boundary) ||
        (std::string(phase) == "fluid" && !with_fluid))
      continue;
    const auto x = phase_positions(frame, phase);
    all.insert(all.end(), x.begin(), x.end());
  }
  return all;
}

bool SnapshotRenderer::has_yarns(const io::Frame& frame) const {
  const io::Phase* p = frame.find("yarn");
  return style_.knit_yarns && p && p->find("position") && p->find("position")->count > 0;
}

void SnapshotRenderer::start_surface(const io::Frame& frame, const Region* only) {
  last_surface_seconds_ = 0;
  surface_triangles_ = 0;
  surface_started_ = false;
  meshes_.upload({});
  if (!style_.fluid_surface)
    return;
  const auto x = phase_positions(frame, "fluid");
  if (!fluid_r_ && x.size() > 1)
    fluid_r_ = 0.5 * typical_spacing(x);
  if (x.empty() || !fluid_r_ || !(*fluid_r_ > 0))
    return;
  glm::dvec3 lo(x.front()), hi(x.front());
  SurfaceOptions opt = surface_options();
  if (whole_fluid_) { // a part of the fluid: the grid laid over the whole
    lo = whole_fluid_->lo;
    hi = whole_fluid_->hi;
    opt.box = std::pair(lo, hi);
  } else {
    for (const glm::dvec3& p : x) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  fluid_centre_ = 0.5 * (lo + hi);
  const auto t0 = std::chrono::steady_clock::now();
  if (style_.geometry_on_gpu) {
    if (!surface_compute_) {
      surface_compute_ = std::make_unique<SurfaceCompute>();
      surface_compute_->time_with(&timer_);
    }
    surface_compute_->start(x, opt, only);
    surface_started_ = true;
  } else {
    const SurfaceMesh m = marching_cubes(surface_field(x, opt, only), only);
    meshes_.upload(m);
    surface_triangles_ = m.triangles();
  }
  last_surface_seconds_ =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::size_t SnapshotRenderer::finish_surface() {
  if (surface_started_) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t indices = surface_compute_->finish();
    meshes_.show(surface_compute_->vertex_buffer(), surface_compute_->index_buffer(), indices);
    surface_triangles_ = indices / 3;
    surface_started_ = false;
    last_surface_seconds_ +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return surface_triangles_;
}

std::size_t SnapshotRenderer::knit_tubes(const io::Frame& frame, const Region* only) {
  last_yarn_seconds_ = 0;
  tubes_.clear();
  yarn_meshes_.upload({});
  if (!has_yarns(frame))
    return 0;
  if (!yarn_r_) {
    yarn_r_ = style_.yarn_radius;
    if (!(*yarn_r_ > 0)) // a fifth of a layer's point spacing; without knit points, the yarn's
      *yarn_r_ = 0.2 * layer_spacing(frame, "knit")
                           .value_or(4 * typical_spacing(phase_positions(frame, "yarn")));
  }
  YarnStyle ys;
  ys.radius = *yarn_r_;
  ys.wet_darkening = style_.wet_darkening;
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t triangles = 0;
  if (style_.geometry_on_gpu) {
    // A part's volumetric yarns: every segment within their reach of it (its layer cuts them
    // at its faces; as shadow casters a segment drawn by two parts is the nearest once).
    tubes_.build(yarn_points_of(frame), ys, only, only && style_.knit_volume ? yarn_reach() : 0.0);
    triangles = tubes_.triangles();
  } else {
    const YarnPolylines lines{phase_positions(frame, "yarn"), segments(frame, "yarn"),
                              scalar_field(frame, "yarn", "saturation")};
    const SurfaceMesh m = yarn_tubes(lines, ys, only);
    yarn_meshes_.upload(m);
    triangles = m.triangles();
  }
  last_yarn_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  timer_.mark("yarns");
  return triangles;
}

void SnapshotRenderer::draw_scene(const ViewMatrices& view, const Lighting& light, bool picture) {
  spheres_.draw(view, light);
  // Translucent water has layers of its own, drawn after the scene; and it casts no shadow: it
  // lets nearly all the light through (Fresnel's few percent mirrored, a little absorbed), which
  // it would focus into caustics, not drawn.
  if (!translucent())
    meshes_.draw(style_.fluid, view, light,
                 {.reflective = picture && style_.fluid_reflection,
                  .environment = picture ? environment_texture_ : 0u});
  // A shadow map takes the tubes with half their sides: an inscribed prism, so a tube does not
  // shadow its own lit side, at half the vertices (the GPU's geometry is what a pass costs).
  // A tube is closed but for a yarn's ends and wound outward: the faces it turns away are hidden
  // behind its own, so the GPU culls them (the picture unchanged). The fluid's surface stays
  // two-sided: a camera may look at it from inside the water.
  if (!picture || !volumetric())
    tubes_.draw(style_.knit, view, light, !picture, true);
  yarn_meshes_.draw(style_.knit, view, light);
  solid_mesh_.draw(style_.obstacle_colour, view, light);
  // The floor receives shadows but casts none; a plane is seen from its front only (a shadow
  // caster from either side).
  if (picture) {
    floor_mesh_.draw(style_.floor_colour, view, light);
    tank_mesh_.draw(style_.floor_colour, view, light, {.one_sided = true});
  }
  plane_mesh_.draw(style_.obstacle_colour, view, light, {.one_sided = picture});
}

void SnapshotRenderer::draw_shadow_maps(const Camera& camera, double aspect, const glm::dvec3& lo,
                                        const glm::dvec3& hi, bool part) {
  if (!shadows_) {
    const int texels = style_.shadow_resolution > 0
                           ? style_.shadow_resolution
                           : std::clamp(2 * std::max(style_.width, style_.height), 256, 2048);
    shadows_ = std::make_unique<ShadowMaps>(texels, style_.shadow_cascades);
  }
  shadows_->fit(camera, aspect, lo, hi, style_.lighting.toward_light);
  glEnable(GL_DEPTH_TEST);
  for (int k = 0; k < shadows_->cascades(); ++k) {
    shadows_->begin(k);
    draw_scene(shadows_->light_view(k), Lighting{}, false);
  }
  if (part && combine_shadows_) {
    std::vector<float> depths = shadows_->read();
    combine_shadows_(depths);
    shadows_->write(depths);
  }
}

void SnapshotRenderer::add_spheres(std::vector<Sphere>& list, const io::Frame& frame,
                                   const std::string& phase, std::optional<double>& radius,
                                   double share, const glm::vec4& colour, bool wet,
                                   const Region* only) const {
  const auto x = phase_positions(frame, phase);
  if (x.empty())
    return;
  if (!radius)
    radius = share * layer_spacing(frame, phase).value_or(0);
  const auto saturation = wet ? scalar_field(frame, phase, "saturation") : std::vector<double>{};
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (only && !only->contains(x[i]))
      continue;
    glm::vec4 c = colour;
    if (!saturation.empty()) {
      const double s = std::clamp(saturation[i], 0.0, 1.0);
      c = glm::vec4(glm::vec3(colour) * float(1 - style_.wet_darkening * std::sqrt(s)), colour.a);
    }
    list.push_back({glm::vec4(glm::vec3(x[i]), float(*radius)), c});
  }
}

unsigned SnapshotRenderer::draw_environment(const io::Frame& frame, const Placed& at,
                                            const glm::dvec3& lo, const glm::dvec3& hi,
                                            const Lighting& lighting) {
  if (!style_.fluid_surface || !style_.fluid_reflection || style_.environment_size <= 0 ||
      surface_triangles_ == 0)
    return 0;
  if (!environment_)
    environment_ = std::make_unique<EnvironmentMap>(style_.environment_size);
  std::vector<Sphere> list = at.spheres;
  add_spheres(list, frame, "knit", knit_r_, 0.6, style_.knit, true, nullptr);
  environment_spheres_.upload(list);
  const double size = std::max(glm::length(hi - lo), 1e-6);
  environment_->render(fluid_centre_, 1e-3 * size, 4 * size, [&](const ViewMatrices& v) {
    environment_spheres_.draw(v, lighting);
    solid_mesh_.draw(style_.obstacle_colour, v, lighting);
    floor_mesh_.draw(style_.floor_colour, v, lighting);
    plane_mesh_.draw(style_.obstacle_colour, v, lighting, {.one_sided = true});
    tank_mesh_.draw(style_.floor_colour, v, lighting, {.one_sided = true});
  });
  timer_.mark("environment");
  return environment_->texture();
}

WaterOptics SnapshotRenderer::optics() const {
  return {style_.refractive_index,
          absorption_for(glm::vec3(style_.fluid), style_.absorption_depth)};
}

io::RgbaImage SnapshotRenderer::draw(const io::Frame& frame, const Camera& camera,
                                     const Region* only) {
  render(frame, camera, only);
  if (translucent())
    return resolved(camera);
  io::RgbaImage image{style_.width, style_.height, target_.read_rgba()};
  timer_.mark("read-back");
  last_passes_ = timer_.read();
  return image;
}

io::RgbaImage SnapshotRenderer::resolved(const Camera& camera) {
  if (!picture_)
    picture_ = std::make_unique<OffscreenTarget>(style_.width, style_.height);
  const double aspect = double(style_.width) / style_.height;
  water_->resolve(target_, ViewMatrices::of(camera, aspect), optics(), *picture_);
  timer_.mark("resolve");
  io::RgbaImage image{style_.width, style_.height, picture_->read_rgba()};
  timer_.mark("read-back");
  last_passes_ = timer_.read();
  return image;
}

std::vector<LayeredPixel> SnapshotRenderer::draw_layers(const io::Frame& frame,
                                                        const Camera& camera, const Region* only) {
  if (!translucent())
    throw Error("render: layers are drawn for translucent water only (the opaque frame "
                "composites by its colour and depth)");
  render(frame, camera, only);
  auto out = water_->read(target_);
  timer_.mark("read-back");
  last_passes_ = timer_.read();
  return out;
}

io::RgbaImage SnapshotRenderer::resolve(std::vector<LayeredPixel> layers,
                                        const std::vector<YarnPixel>& yarns, const Camera& camera) {
  if (!translucent())
    throw Error("render: only translucent water's layers are resolved");
  if (!yarns.empty() && yarns.size() != layers.size())
    throw Error("render: " + std::to_string(yarns.size()) + " yarn pixels over " +
                std::to_string(layers.size()) + " layered ones");
  timer_.begin();
  // The layers run bottom up (GL's rows), the yarns top down (the image's).
  const std::size_t w = std::size_t(style_.width), h = std::size_t(style_.height);
  for (std::size_t k = 0; k < yarns.size(); ++k)
    put_yarns_over(layers[k].opaque, yarns[(h - 1 - k / w) * w + k % w]);
  if (!water_)
    water_ = std::make_unique<WaterLayers>(style_.width, style_.height);
  water_->write(layers, target_);
  timer_.mark("uploads");
  return resolved(camera);
}

io::RgbaImage SnapshotRenderer::composite_picture(std::vector<DepthPixel> pixels,
                                                  const std::vector<YarnPixel>& yarns) const {
  if (!yarns.empty() && yarns.size() != pixels.size())
    throw Error("render: " + std::to_string(yarns.size()) + " yarn pixels over " +
                std::to_string(pixels.size()) + " opaque ones");
  for (std::size_t k = 0; k < yarns.size(); ++k)
    put_yarns_over(pixels[k], yarns[k]);
  return colour_of(pixels, style_.width, style_.height);
}

double SnapshotRenderer::yarn_reach() const {
  // The slices span reach radii of the wet (swollen) yarn about its centre; a little more for
  // the level of detail's merged runs (within half a pixel of the points).
  return 1.05 * style_.lumislice.reach() * yarn_r_.value_or(0) * (1 + YarnStyle{}.swell);
}

std::vector<YarnPixel> SnapshotRenderer::draw_yarn_layer(const Camera& camera, const Region& only,
                                                         const std::vector<float>& opaque_depth) {
  const std::size_t n = std::size_t(style_.width) * std::size_t(style_.height);
  if (opaque_depth.size() != n)
    throw Error("render: an opaque depth of " + std::to_string(opaque_depth.size()) +
                " pixels for a " + std::to_string(style_.width) + " x " +
                std::to_string(style_.height) + " picture");
  std::vector<YarnPixel> out(n, YarnPixel{{0, 0, 0, 0}, 1.0f});
  if (!volumetric())
    return out;
  timer_.begin();
  if (!yarn_layer_)
    yarn_layer_ = std::make_unique<OffscreenTarget>(style_.width, style_.height, true);
  yarn_layer_->write_depth(opaque_depth);
  yarn_layer_->bind();
  glClearColor(0, 0, 0, 0); // a transparent black layer: what the slices add, premultiplied
  glClear(GL_COLOR_BUFFER_BIT);
  timer_.mark("uploads");
  Lighting lighting = style_.lighting;
  if (style_.shadows && shadows_) // the part's draw left the frame's maps (combined) bound
    lighting.shadows = shadows_.get();
  draw_yarn_slices(ViewMatrices::of(camera, double(style_.width) / style_.height), lighting,
                   *yarn_layer_, &only);
  const std::vector<std::uint16_t> rgba = yarn_layer_->read_rgba_half();
  const std::vector<float> depth = yarn_layer_->read_depth();
  for (std::size_t k = 0; k < n; ++k) {
    std::memcpy(out[k].rgba, &rgba[4 * k], sizeof out[k].rgba);
    out[k].depth = depth[k]; // the opaque scene's or a nearer core's: folded by the nearer
  }
  timer_.mark("read-back");
  for (auto& pass : timer_.read())
    last_passes_.push_back({"layer " + pass.first, pass.second});
  return out;
}

void SnapshotRenderer::draw_yarn_slices(const ViewMatrices& view, const Lighting& lighting,
                                        const OffscreenTarget& target, const Region* clip) {
  if (!volume_)
    volume_ = std::make_unique<VolumeYarns>(style_.lumislice, sort_on_cuda_, style_.yarn_slices,
                                            style_.yarn_detail_pixels);
  volume_->order(tubes_, view, *yarn_r_, lighting, style_.height);
  timer_.mark("yarn order");
  // The slices over the opaque scene, back to front; then the yarns' depth, their tubes' (the
  // core the fibres nearly hide), for what is drawn after (the water) and the composite.
  target.bind();
  volume_->draw(tubes_, style_.knit, view, lighting, clip);
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  tubes_.draw(style_.knit, view, Lighting{}, false, true, clip);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  timer_.mark("yarn slices");
}

void SnapshotRenderer::render(const io::Frame& frame, const Camera& camera, const Region* only) {
  const Placed at = placed(frame.time);
  std::vector<Sphere> list;
  for (const Sphere& s : at.spheres)
    if (!only || only->contains(glm::dvec3(glm::vec3(s.centre_radius))))
      list.push_back(s);
  timer_.begin();
  // The surface's passes run on the GPU while the host reads the yarns.
  start_surface(frame, only);
  if (!style_.fluid_surface)
    add_spheres(list, frame, "fluid", fluid_r_, 0.5, style_.fluid, false, only);
  const std::size_t tube_triangles = knit_tubes(frame, only);
  const std::size_t surface_triangles = finish_surface();
  if (!has_yarns(frame))
    add_spheres(list, frame, "knit", knit_r_, 0.6, style_.knit, true, only);
  if (style_.boundary)
    add_spheres(list, frame, "boundary", boundary_r_, 0.5, style_.boundary_colour, false, only);
  // The floor, and the shadow maps of everything drawn (the box and its shadow on the floor).
  const double aspect = double(style_.width) / style_.height;
  auto [lo, hi] = box_of(frame, at);
  SurfaceMesh floor;
  if (style_.floor) {
    const auto& [flo, fhi] = stage_ ? *stage_ : std::pair<glm::dvec3, glm::dvec3>{lo, hi};
    const double z = std::isnan(style_.floor_z) ? flo.z : style_.floor_z;
    floor = floor_square(flo, fhi, z);
    const glm::dvec3 l = glm::normalize(glm::dvec3(style_.lighting.toward_light));
    if (l.z > 1e-3) // the box's shadow on the floor is in the maps' box too
      for (int k = 0; k < 8; ++k) {
        const glm::dvec3 p(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
        const glm::dvec3 q = p - l * ((p.z - z) / l.z);
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
    lo.z = std::min(lo.z, z);
  }
  floor_mesh_.upload(floor);
  spheres_.upload(list);
  // The solids and planes are the scene's: the same every frame and every part of it, drawn
  // whole by each rank (like the floor) so the composite keeps them.
  solid_mesh_.upload(at.solids);
  plane_mesh_.upload(at.planes);
  tank_mesh_.upload(style_.tank);
  timer_.mark("uploads");
  Lighting lighting = style_.lighting;
  if (style_.shadows) {
    draw_shadow_maps(camera, aspect, lo, hi, only != nullptr);
    timer_.mark("shadows");
    lighting.shadows = shadows_.get();
  }
  environment_texture_ = draw_environment(frame, at, lo, hi, lighting);
  const ViewMatrices view = ViewMatrices::of(camera, aspect);
  target_.bind();
  const glm::vec4& bg = style_.background;
  glClearColor(bg.r, bg.g, bg.b, bg.a);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  draw_scene(view, lighting, true);
  // A part of a sort-last frame draws its yarns after the opaque scene's composite
  // (draw_yarn_layer): their slices blend over what lies behind them, in any part.
  if (volumetric() && !only)
    draw_yarn_slices(view, lighting, target_);
  last_spheres_ = list.size();
  last_triangles_ = surface_triangles + tube_triangles;
  timer_.mark("picture");
  if (translucent()) {
    if (!water_)
      water_ = std::make_unique<WaterLayers>(style_.width, style_.height);
    water_->begin_front();
    meshes_.draw(style_.fluid, view, lighting,
                 {.reflective = style_.fluid_reflection,
                  .environment = environment_texture_,
                  .water = MeshLook::Water::Front});
    water_->begin_back();
    meshes_.draw(style_.fluid, view, lighting, {.water = MeshLook::Water::Back});
    timer_.mark("water");
  }
}

} // namespace kf::render
