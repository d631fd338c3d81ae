// Scene loading: TOML text -> overrides -> schema validation -> kf::Scene.
// The schema lives here, one read_* function per table; typed, range-checked access and the
// error wording live in SceneReader, the --set merging in SceneOverrides.
#include "core/Error.hpp"
#include "domain/KnitMeshPiece.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/Scene.hpp"
#include "domain/SceneOverrides.hpp"
#include "domain/SceneReader.hpp"
#include "io/WholeFile.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <span>
#include <sstream>
#include <utility>

namespace kf {

namespace {

using scene::Choice;
using scene::format_vec3;
using scene::Range;
using scene::repr;
using scene::TableReader;

// The spellings in scene files; to_string uses the same tables.
constexpr std::array kModules{
    Choice<Module>{"fluid", Module::Fluid}, Choice<Module>{"boundary", Module::Boundary},
    Choice<Module>{"knit", Module::Knit}, Choice<Module>{"contact", Module::Contact},
    Choice<Module>{"capillary", Module::Capillary}};
constexpr std::array kKnitShapes{Choice<KnitShape>{"patch", KnitShape::Patch},
                                 Choice<KnitShape>{"tube", KnitShape::Tube},
                                 Choice<KnitShape>{"mesh", KnitShape::Mesh}};
constexpr std::array kPrecisions{Choice<Precision>{"float", Precision::Float},
                                 Choice<Precision>{"double", Precision::Double}};
constexpr std::array kKernels{Choice<KernelType>{"spiky", KernelType::Spiky},
                              Choice<KernelType>{"cubic", KernelType::CubicSpline},
                              Choice<KernelType>{"wendland", KernelType::WendlandC2}};
constexpr std::array kNeighbourLists{
    Choice<Scene::Solver::NeighbourLists>{"on", Scene::Solver::NeighbourLists::On},
    Choice<Scene::Solver::NeighbourLists>{"off", Scene::Solver::NeighbourLists::Off},
    Choice<Scene::Solver::NeighbourLists>{"verlet", Scene::Solver::NeighbourLists::Verlet}};
constexpr std::array kTransports{
    Choice<Scene::Parallel::Transport>{"auto", Scene::Parallel::Transport::Auto},
    Choice<Scene::Parallel::Transport>{"mpi", Scene::Parallel::Transport::Mpi},
    Choice<Scene::Parallel::Transport>{"nccl", Scene::Parallel::Transport::Nccl},
    Choice<Scene::Parallel::Transport>{"ipc", Scene::Parallel::Transport::Ipc}};
constexpr std::array kDensityModels{Choice<DensityModel>{"summation", DensityModel::Summation},
                                    Choice<DensityModel>{"continuity", DensityModel::Continuity}};
constexpr std::array kShifting{
    Choice<Scene::Solver::Shifting>{"off", Scene::Solver::Shifting::Off},
    Choice<Scene::Solver::Shifting>{"fickian", Scene::Solver::Shifting::Fickian}};
constexpr std::array kOnInstability{
    Choice<Scene::Solver::OnInstability>{"stop", Scene::Solver::OnInstability::Stop},
    Choice<Scene::Solver::OnInstability>{"rollback", Scene::Solver::OnInstability::Rollback}};
constexpr std::array kQualities{
    Choice<Scene::Solver::Quality>{"preview", Scene::Solver::Quality::Preview},
    Choice<Scene::Solver::Quality>{"production", Scene::Solver::Quality::Production},
    Choice<Scene::Solver::Quality>{"reference", Scene::Solver::Quality::Reference}};
constexpr std::array kInitialDensities{
    Choice<Scene::Fluid::InitialDensity>{"rest", Scene::Fluid::InitialDensity::Rest},
    Choice<Scene::Fluid::InitialDensity>{"hydrostatic", Scene::Fluid::InitialDensity::Hydrostatic}};
constexpr std::array kEos{Choice<EosType>{"linear", EosType::Linear},
                          Choice<EosType>{"tait", EosType::Tait}};
constexpr std::array kShapes{Choice<ObstacleShape>{"plane", ObstacleShape::Plane},
                             Choice<ObstacleShape>{"box", ObstacleShape::Box},
                             Choice<ObstacleShape>{"sphere", ObstacleShape::Sphere},
                             Choice<ObstacleShape>{"mesh", ObstacleShape::Mesh}};
// Index into Scene::Domain::walls.
constexpr std::array kWalls{Choice<int>{"x-", 0}, Choice<int>{"x+", 1}, Choice<int>{"y-", 2},
                            Choice<int>{"y+", 3}, Choice<int>{"z-", 4}, Choice<int>{"z+", 5}};

bool all_less(const Vec3d& a, const Vec3d& b) {
  return a.x < b.x && a.y < b.y && a.z < b.z;
}
bool all_less_equal(const Vec3d& a, const Vec3d& b) {
  return a.x <= b.x && a.y <= b.y && a.z <= b.z;
}

/// The required min/max of a box-like table, with max > min in every axis.
std::pair<Vec3d, Vec3d> read_box(const TableReader& t) {
  const Vec3d lo = t.require_vec3("min");
  const Vec3d hi = t.require_vec3("max");
  if (!all_less(lo, hi))
    t.fail_key(*t.node("max"), "max",
               "every component > " + t.key_path("min") + " " + format_vec3(lo),
               repr(*t.node("max")));
  return {lo, hi};
}

void read_simulation(const TableReader& t, Scene& s) {
  t.allow_only({"name", "end_time", "gravity", "modules", "precision"});
  t.read("name", s.name);
  s.end_time = t.require("end_time", Range::positive());
  t.read("gravity", s.gravity);
  if (!t.read_set("modules", s.modules, kModules))
    t.fail_missing("modules");
  const toml::node& modules = *t.node("modules");
  if (s.modules.empty())
    t.fail_key(modules, "modules", "at least one module (\"fluid\", \"boundary\", \"knit\")",
               "none");
  if (s.has(Module::Fluid) && !s.has(Module::Boundary))
    t.fail_key(modules, "modules",
               "\"boundary\" as well (module \"fluid\" requires module \"boundary\")",
               repr(modules));
  for (Module m : {Module::Contact, Module::Capillary})
    if (s.has(m) && !(s.has(Module::Fluid) && s.has(Module::Knit)))
      t.fail_key(modules, "modules",
                 "\"fluid\" and \"knit\" as well (module \"" + to_string(m) + "\" couples them)",
                 repr(modules));
  t.read("precision", s.precision, kPrecisions);
}

void read_coupling(const TableReader& t, Scene& s) {
  t.allow_only(
      {"fluid_radius", "knit_radius", "stiffness", "damping_ratio", "friction", "sheet_guard"});
  auto& c = s.coupling;
  constexpr std::array kGuards{
      Choice<Scene::Coupling::SheetGuard>{"auto", Scene::Coupling::SheetGuard::Auto},
      Choice<Scene::Coupling::SheetGuard>{"on", Scene::Coupling::SheetGuard::On},
      Choice<Scene::Coupling::SheetGuard>{"off", Scene::Coupling::SheetGuard::Off}};
  t.read("sheet_guard", c.sheet_guard, kGuards);
  t.read("fluid_radius", c.fluid_radius, Range::at_least(0));
  t.read("knit_radius", c.knit_radius, Range::at_least(0));
  t.read("stiffness", c.stiffness, Range::at_least(0));
  t.read("damping_ratio", c.damping_ratio, Range::at_least(0));
  t.read("friction", c.friction, Range::at_least(0));
  if (t.present() && !s.has(Module::Contact))
    t.fail(nullptr, "table '" + t.path() +
                        "': module \"contact\" is not in simulation.modules, so nothing reads it");
}

void read_capillary(const TableReader& t, Scene& s) {
  t.allow_only({"model", "emit_saturation", "porosity", "permeability", "sigma"});
  auto& c = s.capillary;
  constexpr std::array kModels{
      Choice<Scene::AbsorptionModel>{"paper", Scene::AbsorptionModel::Paper},
      Choice<Scene::AbsorptionModel>{"conserving", Scene::AbsorptionModel::Conserving}};
  t.read("model", c.model, kModels);
  t.read("emit_saturation", c.emit_saturation, Range::at_least(1));
  t.read("porosity", c.porosity, Range::above_up_to(0, 1));
  t.read("permeability", c.permeability, Range::positive());
  t.read("sigma", c.sigma, Range::at_least(0));
  if (t.present() && !s.has(Module::Capillary))
    t.fail(nullptr,
           "table '" + t.path() +
               "': module \"capillary\" is not in simulation.modules, so nothing reads it");
}

void read_domain(const TableReader& t, Scene::Domain& d) {
  t.allow_only({"min", "max", "walls"});
  std::tie(d.min, d.max) = read_box(t);
  std::vector<int> walls;
  if (t.read_set("walls", walls, kWalls)) {
    d.walls.fill(false);
    for (int w : walls)
      d.walls[static_cast<std::size_t>(w)] = true;
  }
}

void read_output(const TableReader& t, Scene& s) {
  t.allow_only(
      {"dir", "interval", "enabled", "checkpoint_steps", "checkpoint_seconds", "checkpoint_keep"});
  s.output.dir = "out/" + s.name;
  t.read("dir", s.output.dir);
  t.read("interval", s.output.interval, Range::positive());
  t.read("enabled", s.output.enabled);
  t.read_integer("checkpoint_steps", s.output.checkpoint_steps, 0);
  t.read("checkpoint_seconds", s.output.checkpoint_seconds, Range::at_least(0));
  t.read_integer("checkpoint_keep", s.output.checkpoint_keep, 1);
}

void read_solver(const TableReader& t, Scene::Solver& sv) {
  t.allow_only({"kernel",
                "cfl",
                "force_factor",
                "viscous_factor",
                "dt_max",
                "dt_min",
                "max_steps",
                "damping",
                "damping_until",
                "cell_span",
                "cell_order",
                "neighbour_list",
                "neighbour_skin",
                "density",
                "density_diffusion",
                "shifting",
                "shifting_coefficient",
                "shifting_surface",
                "quality",
                "watchdog_steps",
                "watchdog_max_speed",
                "watchdog_density_error",
                "watchdog_energy_rise",
                "on_instability",
                "rollback_retries"});
  t.read("quality", sv.quality, kQualities);
  t.read_integer("watchdog_steps", sv.watchdog_steps, 0);
  t.read("watchdog_max_speed", sv.watchdog_max_speed, Range::at_least(0));
  t.read("watchdog_density_error", sv.watchdog_density_error, Range::positive());
  t.read("watchdog_energy_rise", sv.watchdog_energy_rise, Range::positive());
  t.read("on_instability", sv.on_instability, kOnInstability);
  t.read_integer("rollback_retries", sv.rollback_retries, 0);
  t.read("kernel", sv.kernel, kKernels);
  t.read("neighbour_list", sv.neighbour_list, kNeighbourLists);
  t.read("neighbour_skin", sv.neighbour_skin, Range::above_up_to(0, 1));
  t.read("density", sv.density, kDensityModels);
  t.read("density_diffusion", sv.density_diffusion, Range::at_least(0));
  t.read("shifting", sv.shifting, kShifting);
  t.read("shifting_coefficient", sv.shifting_coefficient, Range::above_up_to(0, 10));
  t.read("shifting_surface", sv.shifting_surface, Range::closed(0, 3));
  t.read("cfl", sv.cfl, Range::above_up_to(0, 1));
  t.read("force_factor", sv.force_factor, Range::above_up_to(0, 1));
  t.read("viscous_factor", sv.viscous_factor, Range::above_up_to(0, 1));
  t.read("dt_max", sv.dt_max, Range::positive());
  t.read("dt_min", sv.dt_min, Range::positive());
  if (sv.dt_min >= sv.dt_max) {
    // Blame the key the user wrote (dt_min when both are given).
    if (const toml::node* n = t.node("dt_min"))
      t.fail_key(*n, "dt_min",
                 "a number < " + t.key_path("dt_max") + " (" + scene::format_number(sv.dt_max) +
                     ")",
                 repr(*n));
    const toml::node& n = *t.node("dt_max");
    t.fail_key(n, "dt_max",
               "a number > " + t.key_path("dt_min") + " (" + scene::format_number(sv.dt_min) + ")",
               repr(n));
  }
  t.read_integer("max_steps", sv.max_steps, 0);
  if (t.read_integer("cell_span", sv.cell_span, 1) && sv.cell_span > 3)
    t.fail_key(*t.node("cell_span"), "cell_span", "an integer from 1 to 3",
               std::to_string(sv.cell_span));
  if (t.read_integer("cell_order", sv.cell_order, 0) && sv.cell_order > kMaxOrderLevels)
    t.fail_key(*t.node("cell_order"), "cell_order",
               "an integer from 0 to " + std::to_string(kMaxOrderLevels),
               std::to_string(sv.cell_order));
  t.read("damping", sv.damping, Range::at_least(0));
  t.read("damping_until", sv.damping_until, Range::at_least(0));
}

/// speed_of_sound, or stiffness k of the linear EOS (c = sqrt(k)); never both.
void read_sound_speed(const TableReader& t, Scene::Fluid& f) {
  const bool has_c = t.read("speed_of_sound", f.speed_of_sound, Range::positive());
  double k = 0;
  if (!t.read("stiffness", k, Range::positive()))
    return;
  const toml::node& n = *t.node("stiffness");
  if (has_c)
    t.fail_key(n, "stiffness", "either stiffness or speed_of_sound, not both",
               "both (speed_of_sound = " + repr(*t.node("speed_of_sound")) + ")");
  if (f.eos != EosType::Linear)
    t.fail_key(n, "stiffness",
               "no stiffness with eos = \"tait\" (stiffness is k of eos = \"linear\"; "
               "for tait give speed_of_sound)",
               repr(n));
  f.speed_of_sound = std::sqrt(k);
}

FluidBlock read_block(const TableReader& t, const Scene::Domain& d) {
  t.allow_only({"min", "max", "velocity", "jitter"});
  FluidBlock b;
  std::tie(b.min, b.max) = read_box(t);
  const bool min_in = all_less_equal(d.min, b.min) && all_less_equal(b.min, d.max);
  if (!min_in || !all_less_equal(b.max, d.max)) {
    const char* key = min_in ? "max" : "min";
    t.fail_key(*t.node(key), key,
               "a point inside the domain " + format_vec3(d.min) + ".." + format_vec3(d.max),
               repr(*t.node(key)));
  }
  t.read("velocity", b.velocity);
  t.read("jitter", b.jitter, Range::closed(0, 0.5)); // within the particle's own cell
  return b;
}

void read_fluid(const TableReader& t, Scene& s) {
  t.allow_only({"spacing", "support", "rest_density", "eos", "speed_of_sound", "stiffness",
                "tait_exponent", "viscosity", "artificial_viscosity", "clamp_negative_pressure",
                "no_slip", "initial_density", "block"});
  Scene::Fluid& f = s.fluid;
  t.read("spacing", f.spacing, Range::positive());
  t.read("support", f.support, Range::closed(1.0, 4.0));
  t.read("rest_density", f.rest_density, Range::positive());
  t.read("eos", f.eos, kEos);
  read_sound_speed(t, f);
  t.read("tait_exponent", f.tait_exponent, Range::at_least(1));
  t.read("viscosity", f.viscosity, Range::at_least(0));
  t.read("artificial_viscosity", f.artificial_viscosity, Range::closed(0, 1));
  t.read("clamp_negative_pressure", f.clamp_negative_pressure);
  t.read("no_slip", f.no_slip);
  // Read under summation too, which computes the density from the particles and so ignores it:
  // a scene keeps its start when a run switches the density model (--set solver.density=...).
  t.read("initial_density", f.initial_density, kInitialDensities);
  for (const TableReader& b : t.array_of_tables("block"))
    f.blocks.push_back(read_block(b, s.domain));
}

/// Every fluid block holds particles at the spacing (a spacing larger than a block's side places
/// none there: a scene that would run without its fluid).
void check_blocks_hold_particles(const TableReader& fluid, const Scene& s) {
  if (!s.has(Module::Fluid))
    return;
  const auto blocks = fluid.array_of_tables("block");
  for (std::size_t i = 0; i < s.fluid.blocks.size() && i < blocks.size(); ++i) {
    const Vec3d e = s.fluid.blocks[i].max - s.fluid.blocks[i].min;
    const double side = std::min({e.x, e.y, e.z});
    if (side < s.fluid.spacing * (1 - 1e-9)) {
      std::ostringstream got;
      got << "a block whose smallest side is " << side << " m: it holds no particle at "
          << "fluid.spacing = " << s.fluid.spacing << " m";
      blocks[i].fail_key(*blocks[i].node("max"), "max",
                         "a block at least one spacing (" + std::to_string(s.fluid.spacing) +
                             " m) on every side",
                         got.str());
    }
  }
}

/// Fluid blocks exist exactly when the fluid module is on.
void check_fluid_blocks(const TableReader& sim, const TableReader& fluid, const Scene& s) {
  const bool on = s.has(Module::Fluid);
  if (on && s.fluid.blocks.empty())
    fluid.fail(fluid.present() ? nullptr : sim.node("modules"),
               "key 'fluid.block': expected at least one [[fluid.block]] (module \"fluid\" is in "
               "simulation.modules), got none");
  if (!on && !s.fluid.blocks.empty())
    fluid.fail_key(*fluid.node("block"), "block",
                   "no [[fluid.block]] (module \"fluid\" is not in simulation.modules)",
                   std::to_string(s.fluid.blocks.size()) + " block(s)");
}

constexpr std::array<std::string_view, 3> kCommonObstacleKeys{"shape", "name", "velocity"};

/// The keys of each shape beyond the common ones.
std::span<const std::string_view> shape_keys(ObstacleShape shape) {
  static constexpr std::string_view plane[] = {"point", "normal"}, box[] = {"min", "max"},
                                    sphere[] = {"center", "radius"},
                                    mesh[] = {"file", "scale", "translate"};
  switch (shape) {
  case ObstacleShape::Plane:
    return plane;
  case ObstacleShape::Box:
    return box;
  case ObstacleShape::Sphere:
    return sphere;
  case ObstacleShape::Mesh:
    return mesh;
  }
  return {};
}

/// The keys every obstacle may have plus those of the given shapes.
template <typename Shapes>
std::vector<std::string_view> obstacle_keys(const Shapes& shapes) {
  std::vector<std::string_view> keys(kCommonObstacleKeys.begin(), kCommonObstacleKeys.end());
  for (ObstacleShape shape : shapes)
    for (std::string_view k : shape_keys(shape))
      keys.push_back(k);
  return keys;
}

/// A key of another shape is an error of its own ("radius" on a box), not an unknown key.
void check_shape_keys(const TableReader& t, ObstacleShape shape) {
  const auto bad = t.first_key_not_in(obstacle_keys(std::array{shape}));
  if (!bad)
    return;
  const std::string name(scene::choice_name(kShapes, shape));
  std::string own;
  for (std::string_view k : shape_keys(shape))
    own += (own.empty() ? "" : ", ") + std::string(k);
  t.fail(t.node(*bad), "table '" + t.path() + "': key '" + std::string(*bad) +
                           "' does not apply to shape '" + name + "' (a " + name + " takes " + own +
                           ")");
}

Vec3d read_unit_normal(const TableReader& t) {
  const Vec3d n = t.require_vec3("normal");
  const double len = norm(n);
  if (len == 0)
    t.fail_key(*t.node("normal"), "normal", "a non-zero vector", repr(*t.node("normal")));
  return n * (1.0 / len);
}

/// A mesh obstacle: its OBJ file (relative to the scene file's directory) read, checked to bound
/// a solid and its signed distance sampled now, so a broken mesh fails with the scene's line.
void read_mesh(const TableReader& t, Obstacle& o, const std::filesystem::path& scene_dir) {
  if (!t.read("file", o.file))
    t.fail_missing("file");
  t.read("scale", o.scale, Range::positive());
  t.read("translate", o.translate);
  o.file = (scene_dir / o.file).lexically_normal().string();
  try {
    o.mesh = load_mesh_obstacle(o.file, o.scale, o.translate);
  } catch (const SceneError&) {
    throw;
  } catch (const Error& e) {
    t.fail(t.node("file"), "key '" + t.key_path("file") + "': " + e.what());
  }
}

Obstacle read_obstacle(const TableReader& t, std::size_t index,
                       const std::filesystem::path& scene_dir) {
  t.allow_only(obstacle_keys(std::array{ObstacleShape::Plane, ObstacleShape::Box,
                                        ObstacleShape::Sphere, ObstacleShape::Mesh}));
  Obstacle o;
  o.shape = t.require("shape", kShapes);
  check_shape_keys(t, o.shape);
  o.name = "obstacle[" + std::to_string(index) + "]";
  t.read("name", o.name);
  t.read("velocity", o.velocity);
  switch (o.shape) {
  case ObstacleShape::Plane:
    o.point = t.require_vec3("point");
    o.normal = read_unit_normal(t);
    break;
  case ObstacleShape::Box:
    std::tie(o.min, o.max) = read_box(t);
    break;
  case ObstacleShape::Sphere:
    o.center = t.require_vec3("center");
    o.radius = t.require("radius", Range::positive());
    break;
  case ObstacleShape::Mesh:
    read_mesh(t, o, scene_dir);
    break;
  }
  return o;
}

int read_count(const TableReader& t, std::string_view key, int value, long min, long max) {
  long v = value;
  if (t.read_integer(key, v, min) && v > max)
    t.fail_key(*t.node(key), key, "an integer <= " + std::to_string(max), repr(*t.node(key)));
  return static_cast<int>(v);
}

/// `pattern` (a named chart) or `chart` (rows of K and P), not both.
void read_stitch_chart(const TableReader& t, KnitPiece& k) {
  const toml::node* pattern = t.node("pattern");
  const toml::node* chart = t.node("chart");
  if (pattern && chart)
    t.fail_key(*chart, "chart", "either 'pattern' or 'chart', not both", repr(*chart));
  if (pattern) {
    constexpr std::array<Choice<int>, 4> kPatterns{Choice<int>{"stockinette", 0},
                                                   Choice<int>{"garter", 1}, Choice<int>{"rib", 2},
                                                   Choice<int>{"seed", 3}};
    int which = 0;
    t.read("pattern", which, kPatterns);
    static const std::vector<std::string> charts[4] = {{"K"}, {"K", "P"}, {"KP"}, {"KP", "PK"}};
    k.chart = charts[which];
  }
  if (!chart)
    return;
  const std::string expected = "a non-empty array of equally long strings of 'K' and 'P'";
  const toml::array* rows = chart->as_array();
  if (!rows || rows->empty())
    t.fail_key(*chart, "chart", expected, repr(*chart));
  k.chart.clear();
  for (std::size_t r = 0; r < rows->size(); ++r) {
    const toml::node& row = *rows->get(r);
    const auto* text = row.as_string();
    const std::string key = "chart[" + std::to_string(r) + "]";
    if (!text || text->get().empty() || text->get().find_first_not_of("KP") != std::string::npos ||
        (r > 0 && text->get().size() != k.chart[0].size()))
      t.fail_key(row, key, expected, repr(row));
    k.chart.push_back(text->get());
  }
}

/// `colours` (a table of single letters naming linear RGB colours) and `colour_chart` (rows of
/// those letters, equally long), both or neither.
void read_colour_chart(const TableReader& t, KnitPiece& k) {
  const toml::node* colours = t.node("colours");
  const toml::node* chart = t.node("colour_chart");
  if (!colours && !chart)
    return;
  if (!colours)
    t.fail_key(*chart, "colour_chart", "a chart beside a 'colours' table naming its letters",
               repr(*chart));
  if (!chart)
    t.fail_missing("colour_chart");
  const toml::table* table = colours->as_table();
  if (!table || table->empty())
    t.fail_key(*colours, "colours", "a table of letters naming colours ({ A = [0.8, 0.1, 0.1] })",
               repr(*colours));
  const TableReader named = t.table("colours");
  for (auto&& [key, value] : *table) {
    const std::string name(key.str());
    if (name.size() != 1 || !std::isalpha(static_cast<unsigned char>(name[0])))
      t.fail_key(value, "colours." + name, "a key of a single letter naming a colour", name);
    Vec3d c{};
    named.read(name, c);
    for (double v : {c.x, c.y, c.z})
      if (!(v >= 0 && v <= 1))
        t.fail_key(value, "colours." + name, "a colour: three numbers in [0, 1] (linear RGB)",
                   repr(value));
    k.colours[name[0]] = c;
  }
  std::string letters;
  for (const auto& [letter, c] : k.colours)
    letters += letter;
  const std::string expected =
      "a non-empty array of equally long strings of the letters of 'colours' (" + letters + ")";
  const toml::array* rows = chart->as_array();
  if (!rows || rows->empty())
    t.fail_key(*chart, "colour_chart", expected, repr(*chart));
  for (std::size_t r = 0; r < rows->size(); ++r) {
    const toml::node& row = *rows->get(r);
    const auto* text = row.as_string();
    if (!text || text->get().empty() ||
        text->get().find_first_not_of(letters) != std::string::npos ||
        (r > 0 && text->get().size() != k.colour_chart[0].size()))
      t.fail_key(row, "colour_chart[" + std::to_string(r) + "]", expected, repr(row));
    k.colour_chart.push_back(text->get());
  }
}

/// A knit piece of shape "mesh": its OBJ quad mesh (relative to the scene file's directory, placed
/// by scale and translate as a mesh obstacle is) read and checked now, so a broken mesh fails
/// with the scene's line. Keys of the grid shapes are an error of their own, not unknown keys.
KnitPiece read_knit_mesh_piece(const TableReader& t, std::size_t index, const Scene::Domain& d,
                               const std::filesystem::path& scene_dir) {
  static constexpr std::string_view mesh_keys[] = {"shape", "name",      "file",
                                                   "scale", "translate", "velocity"};
  t.allow_only({"shape", "name", "center", "normal", "u_axis", "width", "height", "circumference",
                "length", "wales", "courses", "velocity", "file", "scale", "translate"});
  if (const auto bad = t.first_key_not_in(mesh_keys))
    t.fail(t.node(*bad), "table '" + t.path() + "': key '" + std::string(*bad) +
                             "' does not apply to shape 'mesh' (a mesh takes file, scale, "
                             "translate, besides name and velocity)");
  KnitPiece k;
  k.shape = KnitShape::Mesh;
  k.name = "knit.piece[" + std::to_string(index) + "]";
  t.read("name", k.name);
  if (!t.read("file", k.file))
    t.fail_missing("file");
  t.read("scale", k.scale, Range::positive());
  t.read("translate", k.translate);
  t.read("velocity", k.velocity);
  k.file = (scene_dir / k.file).lexically_normal().string();
  try {
    k.mesh = load_knit_quad_mesh(k.file, k.scale, k.translate);
  } catch (const SceneError&) {
    throw;
  } catch (const Error& e) {
    t.fail(t.node("file"), "key '" + t.key_path("file") + "': " + e.what());
  }
  if (!all_less_equal(d.min, k.mesh->lo) || !all_less_equal(k.mesh->hi, d.max))
    t.fail_key(*t.node("file"), "file",
               "a mesh inside the domain " + format_vec3(d.min) + ".." + format_vec3(d.max) +
                   " (after scale and translate)",
               "one spanning " + format_vec3(k.mesh->lo) + ".." + format_vec3(k.mesh->hi));
  return k;
}

KnitPiece read_knit_piece(const TableReader& t, std::size_t index, const Scene::Domain& d,
                          const std::filesystem::path& scene_dir) {
  KnitPiece k;
  k.shape = t.require("shape", kKnitShapes);
  if (k.shape == KnitShape::Mesh)
    return read_knit_mesh_piece(t, index, d, scene_dir);
  if (k.shape == KnitShape::Patch)
    t.allow_only({"shape", "name", "center", "normal", "u_axis", "width", "height", "wales",
                  "courses", "velocity", "pattern", "chart", "colours", "colour_chart"});
  else
    t.allow_only({"shape", "name", "center", "normal", "u_axis", "circumference", "length", "wales",
                  "courses", "velocity", "pattern", "chart", "colours", "colour_chart"});
  k.name = "knit.piece[" + std::to_string(index) + "]";
  t.read("name", k.name);
  k.center = t.require_vec3("center");
  if (!all_less_equal(d.min, k.center) || !all_less_equal(k.center, d.max))
    t.fail_key(*t.node("center"), "center",
               "a point inside the domain " + format_vec3(d.min) + ".." + format_vec3(d.max),
               repr(*t.node("center")));
  if (t.node("normal"))
    k.normal = read_unit_normal(t);
  if (t.read("u_axis", k.u_axis)) {
    const Vec3d u = k.u_axis - k.normal * dot(k.u_axis, k.normal);
    if (norm(u) < 1e-6 * norm(k.u_axis) || norm(k.u_axis) == 0)
      t.fail_key(*t.node("u_axis"), "u_axis", "a vector not parallel to normal",
                 repr(*t.node("u_axis")));
  }
  if (k.shape == KnitShape::Patch) {
    t.read("width", k.width, Range::positive());
    t.read("height", k.height, Range::positive());
  } else {
    t.read("circumference", k.circumference, Range::positive());
    t.read("length", k.length, Range::positive());
  }
  k.wales = read_count(t, "wales", k.wales, k.shape == KnitShape::Tube ? 3 : 1, 100000);
  k.courses = read_count(t, "courses", k.courses, 1, 100000);
  t.read("velocity", k.velocity);
  read_stitch_chart(t, k);
  read_colour_chart(t, k);
  return k;
}

KnitPin read_knit_pin(const TableReader& t, std::size_t index) {
  t.allow_only({"name", "min", "max", "velocity", "move_until"});
  KnitPin p;
  p.name = "knit.pin[" + std::to_string(index) + "]";
  t.read("name", p.name);
  std::tie(p.min, p.max) = read_box(t);
  t.read("velocity", p.velocity);
  t.read("move_until", p.move_until, Range::at_least(0));
  return p;
}

void read_knit(const TableReader& sim, const TableReader& t, Scene& s,
               const std::filesystem::path& scene_dir) {
  t.allow_only({"thickness", "mass_per_area", "stretch", "shear", "bend", "compression",
                "layer_shear", "damping_ratio", "contact_radius", "friction", "substeps",
                "spring_factor", "self_collision", "self_radius", "self_stiffness", "self_friction",
                "yarn_samples", "piece", "pin"});
  auto& k = s.knit;
  t.read("thickness", k.thickness, Range::positive());
  t.read("mass_per_area", k.mass_per_area, Range::positive());
  t.read("stretch", k.stretch, Range::positive());
  t.read("shear", k.shear, Range::at_least(0));
  t.read("bend", k.bend, Range::at_least(0));
  t.read("compression", k.compression, Range::positive());
  t.read("layer_shear", k.layer_shear, Range::at_least(0));
  t.read("damping_ratio", k.damping_ratio, Range::closed(0, 10));
  t.read("contact_radius", k.contact_radius, Range::at_least(0));
  t.read("friction", k.friction, Range::at_least(0));
  k.substeps = read_count(t, "substeps", k.substeps, 1, 10000);
  t.read("spring_factor", k.spring_factor, Range::above_up_to(0, 1.4));
  t.read("self_collision", k.self_collision);
  t.read("self_radius", k.self_radius, Range::at_least(0));
  t.read("self_stiffness", k.self_stiffness, Range::at_least(0));
  t.read("self_friction", k.self_friction, Range::at_least(0));
  k.yarn_samples = read_count(t, "yarn_samples", k.yarn_samples, 0, 64);
  const auto pieces = t.array_of_tables("piece");
  if (pieces.size() > 65535)
    t.fail_key(*t.node("piece"), "piece", "at most 65535 pieces", std::to_string(pieces.size()));
  for (std::size_t i = 0; i < pieces.size(); ++i)
    k.pieces.push_back(read_knit_piece(pieces[i], i, s.domain, scene_dir));
  const auto pins = t.array_of_tables("pin");
  for (std::size_t i = 0; i < pins.size(); ++i)
    k.pins.push_back(read_knit_pin(pins[i], i));
  const bool on = s.has(Module::Knit);
  if (on && k.pieces.empty())
    t.fail(t.present() ? nullptr : sim.node("modules"),
           "key 'knit.piece': expected at least one [[knit.piece]] (module \"knit\" is in "
           "simulation.modules), got none");
  if (!on && !k.pieces.empty())
    t.fail_key(*t.node("piece"), "piece",
               "no [[knit.piece]] (module \"knit\" is not in simulation.modules)",
               std::to_string(k.pieces.size()) + " piece(s)");
}

/// [parallel]: the decomposition into blocks and its rebalancing (domain/Decomposition).
void read_parallel(const TableReader& t, Scene::Parallel& p) {
  t.allow_only({"block_cells", "imbalance", "check_every", "payback", "transport", "overlap"});
  p.block_cells = read_count(t, "block_cells", p.block_cells, 1, 1024);
  t.read("imbalance", p.imbalance, Range::at_least(1));
  p.check_every = read_count(t, "check_every", p.check_every, 1, 1000000000);
  t.read("payback", p.payback);
  t.read("transport", p.transport, kTransports);
  t.read("overlap", p.overlap);
}

constexpr std::array kRenderFluids{
    Choice<Scene::Render::Fluid>{"surface", Scene::Render::Fluid::Surface},
    Choice<Scene::Render::Fluid>{"spheres", Scene::Render::Fluid::Spheres}};
constexpr std::array kRenderKnits{
    Choice<Scene::Render::Knit>{"yarns", Scene::Render::Knit::Yarns},
    Choice<Scene::Render::Knit>{"points", Scene::Render::Knit::Points}};
constexpr std::array kSurfaceFields{
    Choice<Scene::Render::SurfaceField>{"weighted", Scene::Render::SurfaceField::Weighted},
    Choice<Scene::Render::SurfaceField>{"naive", Scene::Render::SurfaceField::Naive}};

void read_colour(const TableReader& t, std::string_view key, Vec3d& c) {
  if (!t.read(key, c))
    return;
  for (double v : {c.x, c.y, c.z})
    if (!(v >= 0 && v <= 1))
      t.fail_key(*t.node(key), key, "a colour: three numbers in [0, 1] (linear RGB)",
                 repr(*t.node(key)));
}

constexpr std::array<std::string_view, 33> kRenderKeys{"width",
                                                       "height",
                                                       "eye",
                                                       "target",
                                                       "fov",
                                                       "orbit",
                                                       "light",
                                                       "ambient",
                                                       "highlights",
                                                       "background",
                                                       "fluid_colour",
                                                       "knit_colour",
                                                       "wet_darkening",
                                                       "fluid",
                                                       "surface",
                                                       "surface_cell",
                                                       "boundary",
                                                       "knit",
                                                       "yarn_radius",
                                                       "yarn_volume",
                                                       "yarn_plies",
                                                       "yarn_fuzz",
                                                       "yarn_slices",
                                                       "yarn_detail_pixels",
                                                       "shadows",
                                                       "floor",
                                                       "tank",
                                                       "reflections",
                                                       "gpu_geometry",
                                                       "refraction",
                                                       "refractive_index",
                                                       "absorption_depth",
                                                       "environment_map"};

void read_render(const TableReader& t, Scene::Render& r) {
  t.allow_only(kRenderKeys);
  r.width = read_count(t, "width", r.width, 16, 16384);
  r.height = read_count(t, "height", r.height, 16, 16384);
  const bool eye = t.read("eye", r.eye), target = t.read("target", r.target);
  if (eye != target)
    t.fail_missing(eye ? "target" : "eye"); // a camera needs both
  r.camera = eye;
  if (r.camera && !(norm(r.eye - r.target) > 0))
    t.fail_key(*t.node("target"), "target", "a point apart from the eye", repr(*t.node("target")));
  t.read("fov", r.fov, Range::above_up_to(0, 170));
  t.read("orbit", r.orbit);
  if (t.read("light", r.light) && !(norm(r.light) > 0))
    t.fail_key(*t.node("light"), "light", "a direction toward the light (not zero)",
               repr(*t.node("light")));
  t.read("ambient", r.ambient, Range::closed(0, 1));
  t.read("highlights", r.highlights, Range::at_least(0));
  read_colour(t, "background", r.background);
  read_colour(t, "fluid_colour", r.fluid_colour);
  read_colour(t, "knit_colour", r.knit_colour);
  t.read("wet_darkening", r.wet_darkening, Range::closed(0, 1));
  t.read("fluid", r.fluid, kRenderFluids);
  t.read("surface", r.surface, kSurfaceFields);
  t.read("surface_cell", r.surface_cell, Range::closed(0.125, 4));
  t.read("boundary", r.boundary);
  t.read("knit", r.knit, kRenderKnits);
  t.read("yarn_radius", r.yarn_radius, Range::at_least(0));
  t.read("yarn_volume", r.yarn_volume);
  r.yarn_plies = read_count(t, "yarn_plies", r.yarn_plies, 1, 16);
  r.yarn_fuzz = read_count(t, "yarn_fuzz", r.yarn_fuzz, 0, 10000);
  r.yarn_slices = read_count(t, "yarn_slices", r.yarn_slices, 1, 4);
  t.read("yarn_detail_pixels", r.yarn_detail_pixels, Range::at_least(0));
  t.read("shadows", r.shadows);
  t.read("floor", r.floor);
  t.read("tank", r.tank);
  t.read("reflections", r.reflections);
  t.read("gpu_geometry", r.gpu_geometry);
  t.read("refraction", r.refraction);
  t.read("refractive_index", r.refractive_index, Range::closed(1, 3));
  t.read("absorption_depth", r.absorption_depth, Range::positive());
  r.environment_map = read_count(t, "environment_map", r.environment_map, 0, 4096);
}

/// [solver] quality: the preset's spacing scale on the fluid, and its settings where the scene
/// gives none of its own (a key the scene or --set writes wins).
void apply_quality(const TableReader& sim, const TableReader& solver, Scene& s) {
  const QualityPreset q = quality_preset(s.solver.quality);
  if (q.contact_at_scene_spacing)
    s.coupling.stiffness_spacing = s.fluid.spacing;
  s.fluid.spacing *= q.spacing_scale;
  s.fluid.speed_of_sound *= q.sound_speed_scale;
  if (q.cfl && !solver.node("cfl"))
    s.solver.cfl = *q.cfl;
  if (q.density && !solver.node("density"))
    s.solver.density = *q.density;
  if (q.neighbour_list && !solver.node("neighbour_list"))
    s.solver.neighbour_list = *q.neighbour_list;
  if (q.precision && !sim.node("precision"))
    s.precision = *q.precision;
}

Scene build_scene(const TableReader& root, const std::filesystem::path& scene_dir) {
  root.allow_only({"simulation", "domain", "output", "solver", "fluid", "obstacle", "knit",
                   "coupling", "capillary", "parallel", "render"});
  Scene s;
  const TableReader sim = root.table("simulation");
  read_simulation(sim, s);
  read_domain(root.table("domain"), s.domain);
  read_output(root.table("output"), s);
  const TableReader solver = root.table("solver");
  read_solver(solver, s.solver);
  const TableReader fluid = root.table("fluid");
  read_fluid(fluid, s);
  apply_quality(sim, solver, s);
  check_fluid_blocks(sim, fluid, s);
  check_blocks_hold_particles(fluid, s);
  const auto obstacles = root.array_of_tables("obstacle");
  for (std::size_t i = 0; i < obstacles.size(); ++i)
    s.obstacles.push_back(read_obstacle(obstacles[i], i, scene_dir));
  read_knit(sim, root.table("knit"), s, scene_dir);
  read_coupling(root.table("coupling"), s);
  read_capillary(root.table("capillary"), s);
  read_parallel(root.table("parallel"), s.parallel);
  read_render(root.table("render"), s.render);
  return s;
}

toml::table parse_toml(const std::string& text, const std::string& source_name) {
  try {
    return toml::parse(text, std::string_view(source_name));
  } catch (const toml::parse_error& e) {
    const auto& at = e.source().begin;
    throw SceneError(source_name + ":" + std::to_string(at.line) + ":" + std::to_string(at.column) +
                     ": TOML syntax error: " + std::string(e.description()));
  }
}

std::string read_file(const std::string& path) {
  io::WholeFile f = io::read_whole_file(path);
  if (f.error)
    throw SceneError(path + ": cannot open scene file (" + std::strerror(f.error) + ")");
  return std::move(f.text);
}

/// The text as read plus one "# --set ..." line per override: a snapshot records what ran.
std::string text_with_overrides(std::string text, const std::vector<std::string>& overrides) {
  if (!overrides.empty() && !text.empty() && text.back() != '\n')
    text += '\n';
  for (const std::string& o : overrides)
    text += "# --set " + o + "\n";
  return text;
}

} // namespace

std::span<const std::string_view> render_table_keys() {
  return kRenderKeys;
}

Scene parse_scene(const std::string& text, const std::string& source_name,
                  const std::vector<std::string>& overrides) {
  // Files a scene names are relative to its directory; "<string>" has none: the working one.
  return parse_scene(text, source_name, overrides,
                     std::filesystem::path(source_name).parent_path().string());
}

Scene parse_scene(const std::string& text, const std::string& source_name,
                  const std::vector<std::string>& overrides, const std::string& files_dir) {
  toml::table root = parse_toml(text, source_name);
  scene::apply_overrides(root, overrides);
  Scene s = build_scene(TableReader(source_name, &root, ""), files_dir);
  s.path = source_name;
  s.text = text_with_overrides(text, overrides);
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::absolute(files_dir, ec);
  s.files_dir = ec ? files_dir : dir.lexically_normal().string();
  return s;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  return parse_scene(read_file(path), path, overrides);
}

std::string to_string(KernelType k) {
  return std::string(scene::choice_name(kKernels, k));
}
std::string to_string(KnitShape k) {
  return std::string(scene::choice_name(kKnitShapes, k));
}
std::string to_string(EosType e) {
  return std::string(scene::choice_name(kEos, e));
}
std::string to_string(Module m) {
  return std::string(scene::choice_name(kModules, m));
}
std::string to_string(ObstacleShape s) {
  return std::string(scene::choice_name(kShapes, s));
}

} // namespace kf
