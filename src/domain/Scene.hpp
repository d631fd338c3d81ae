#pragma once
// A validated scene: everything a run needs, in SI units, with defaults filled in.
// Produced only by load_scene/parse_scene, which reject anything out of range, so the rest of
// the program can trust every field.
#include "core/Precision.hpp"
#include "core/SolverOptions.hpp"
#include "core/Vec3.hpp"

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace kf {

struct MeshObstacle; // domain/MeshObstacle.hpp
struct KnitQuadMesh; // domain/KnitMeshPiece.hpp

/// Physics modules a scene may ask for (DESIGN §5).
/// Contact and Capillary couple the fluid and the knit (both required).
enum class Module { Fluid, Boundary, Knit, Contact, Capillary };
/// Rigid obstacle shapes; all are solid (fluid stays outside).
enum class ObstacleShape { Plane, Box, Sphere, Mesh };

struct FluidBlock {
  Vec3d min{}, max{};
  Vec3d velocity{0, 0, 0};
  // Each particle moved off its lattice point by up to jitter x spacing / 2 along each axis, the
  // same on every run and rank (a disordered start: a lattice at rest resists shear like a weak
  // solid; docs/PHYSICS.md). 0: the lattice.
  double jitter = 0;
};

struct Obstacle {
  ObstacleShape shape = ObstacleShape::Box;
  std::string name;        // "obstacle[2]" unless given
  Vec3d point{0, 0, 0};    // plane: a point on it
  Vec3d normal{0, 0, 1};   // plane: unit normal pointing into the fluid side
  Vec3d min{}, max{};      // box
  Vec3d center{0, 0, 0};   // sphere
  double radius = 0;       // sphere
  Vec3d velocity{0, 0, 0}; // prescribed translation velocity (0: static)

  // mesh: the OBJ file (a relative path is resolved against the scene file's directory), each
  // vertex x placed at scale * x + translate; the loader checks it and samples its distance.
  std::string file;
  double scale = 1;
  Vec3d translate{0, 0, 0};
  std::shared_ptr<const MeshObstacle> mesh;
};

/// Rest shapes of a knitted piece.
enum class KnitShape { Patch, Tube, Mesh };

/// One knitted piece: its rest mesh is a grid of wales (along u) and courses (along v) stitches
/// (patch, tube) or the quads of an OBJ file (mesh), three layers thick.
struct KnitPiece {
  KnitShape shape = KnitShape::Patch;
  std::string name;      // "knit.piece[0]" unless given
  Vec3d center{0, 0, 0}; // patch: centre of the middle layer; tube: centre of its axis
  Vec3d normal{0, 0, 1}; // patch: the front side (layer 1); tube: the axis
  Vec3d u_axis{1, 0, 0}; // patch: wale direction (made orthogonal to normal); tube: seam side
  double width = 0.2;    // patch: extent along u [m]
  double height = 0.2;   // patch: extent along v = normal x u [m]
  double circumference = 0.2, length = 0.3; // tube [m]
  int wales = 20, courses = 20;             // stitches along u and v
  Vec3d velocity{0, 0, 0};                  // initial velocity
  // Stitch chart: rows of 'K' (knit) and 'P' (purl), row r for courses j with j % rows == r,
  // column c for wales i with i % columns == c. Default stockinette (the paper's).
  std::vector<std::string> chart{"K"};
  // Colours of the stitches: `colour_chart` rows of letters (row r for the yarn of course j
  // with j % rows == r, letter c for wales i with i % columns == c) naming colours of `colours`
  // (linear RGB in [0, 1]); without them, the [render] knit colour. Grid pieces only.
  std::vector<std::string> colour_chart;
  std::map<char, Vec3d> colours;

  // mesh: the OBJ quad mesh (a relative path is resolved against the scene file's directory),
  // each vertex x placed at scale * x + translate; read and checked by the loader.
  std::string file;
  double scale = 1;
  Vec3d translate{0, 0, 0};
  std::shared_ptr<const KnitQuadMesh> mesh;
};

/// Points of the knit whose rest position lies in [min, max] move with `velocity` until
/// `move_until`, then hold still (velocity 0: pinned).
struct KnitPin {
  std::string name;
  Vec3d min{}, max{};
  Vec3d velocity{0, 0, 0};
  double move_until = 1e300; // [s]
  Vec3d velocity_at(double t) const { return t < move_until ? velocity : Vec3d{0, 0, 0}; }
};

struct Scene {
  std::string path; // file it was read from ("<string>" for text)
  std::string text; // the scene text as read, followed by the --set overrides as comments
  // The folder the files it names are relative to (its file's), absolute.
  std::string files_dir;

  // [simulation]
  std::string name = "scene";
  double end_time = 1.0;
  Vec3d gravity{0, 0, -9.81};
  std::vector<Module> modules;
  Precision precision = Precision::Float;

  // [domain]: the box nothing leaves. walls: x-, x+, y-, y+, z-, z+ (solid outside the box).
  struct Domain {
    Vec3d min{0, 0, 0}, max{1, 1, 1};
    std::array<bool, 6> walls{true, true, true, true, true, true};
  } domain;

  // [output]
  struct Output {
    std::string dir = "out/scene";
    double interval = 0.02; // simulated seconds between snapshots
    bool enabled = true;
    // Full-state checkpoints in dir/checkpoints (P8): every checkpoint_steps steps and every
    // checkpoint_seconds of wall time (0: not by that measure), the newest checkpoint_keep kept.
    // A run killed at any moment resumes with --restart latest.
    long checkpoint_steps = 0;
    double checkpoint_seconds = 600;
    long checkpoint_keep = 2;
  } output;

  // [solver]
  struct Solver {
    KernelType kernel = KernelType::Spiky;
    double cfl = 0.2;            // dt <= cfl * h / (c + v_max)
    double force_factor = 0.25;  // dt <= force_factor * sqrt(h / a_max)
    double viscous_factor = 0.1; // dt <= viscous_factor * h^2 rho0 / mu
    double dt_max = 1e-3;
    double dt_min = 1e-9;     // a step below this is reported as an instability
    long max_steps = 0;       // 0: no limit
    double damping = 0;       // global velocity damping rate zeta [1/s] (settling a rest state)
    double damping_until = 0; // damping acts while t < damping_until
    // Fluid and boundary neighbour grids: cells of h / cell_span, searched cell_span cells on
    // each side. 1: 27 cells of h (27 h^3 of candidates); 2: 125 cells of h/2 (15.6 h^3) but
    // 5x the cell-table reads. docs/PERFORMANCE.md has the measured trade-off.
    long cell_span = 1;
    // Fluid and boundary particles also go in Morton order of 2^cell_order sub-cells a side
    // within each cell (0-2): gathers by nearby lanes then read nearby memory. docs/PERFORMANCE.md.
    long cell_order = 2;
    // Fluid neighbour lists (NeighbourList, fluid and boundary neighbours of each fluid
    // particle): "on" builds them every step (costs more than it saves: docs/PERFORMANCE.md,
    // P4); "verlet" lists everything within the support plus a skin of neighbour_skin * h and
    // keeps the lists (and the fluid's order) until some particle has moved half the skin.
    enum class NeighbourLists { On, Off, Verlet } neighbour_list = NeighbourLists::Off;
    double neighbour_skin = 0.1; // "verlet" lists' skin, in units of the support h (measured best)
    // "summation" (Eq. 2) or "continuity" (drho/dt with delta-SPH diffusion; docs/PHYSICS.md).
    DensityModel density = DensityModel::Summation;
    double density_diffusion = 0.1; // continuity: delta of the diffusion term (0: none)
    // Particle shifting (Lind et al. 2012, in DualSPHysics's Fickian form): after the forces
    // pass each fluid particle moves by -A (h/2) |v| dt grad C, C = sum_j V_j W_ij, to where its
    // neighbours are sparser (at most |v| dt), except at the free surface, where div r =
    // -sum_j V_j r_ij . grad W_ij (about 3 inside 3D water) is below shifting_surface.
    // "off" (default) or "fickian" (docs/PHYSICS.md).
    enum class Shifting { Off, Fickian } shifting = Shifting::Off;
    double shifting_coefficient = 2.0; // A (DualSPHysics's ShiftCoef, -2 there by its sign)
    double shifting_surface = 2.75;    // DualSPHysics's ShiftTFS for 3D
    // A preset of what accuracy costs (P7, docs/VALIDATION.md): "preview" and "reference"
    // scale the fluid's spacing and set the settings the scene does not give itself
    // (quality_preset); "production" and none: the scene as written.
    enum class Quality { None, Preview, Production, Reference } quality = Quality::None;
    // The watchdog (P8, domain/Watchdog): every watchdog_steps steps (0: off) the run checks for
    // non-finite values, a speed past watchdog_max_speed (0: limits set from the scene), a
    // density error past watchdog_density_error and kinetic plus gravitational energy risen past
    // what the run started with (and could have been given) by more than watchdog_energy_rise of
    // it. On a trigger, "stop" ends the run with a report and a diagnostic snapshot; "rollback"
    // goes back to the last checkpoint with cfl and dt_max halved and twice the knit's
    // substeps, at most rollback_retries times.
    long watchdog_steps = 50;
    double watchdog_max_speed = 0;
    double watchdog_density_error = 0.3;
    double watchdog_energy_rise = 0.1;
    enum class OnInstability { Stop, Rollback } on_instability = OnInstability::Stop;
    long rollback_retries = 3;
  } solver;

  // [fluid]
  struct Fluid {
    double spacing = 0.01;        // initial particle spacing dp [m]
    double support = 2.0;         // kernel support radius h in units of dp
    double rest_density = 1000.0; // rho0 [kg/m^3]
    EosType eos = EosType::Tait;
    double speed_of_sound = 20.0; // c [m/s]; the linear EOS uses k = c^2
    double tait_exponent = 7.0;   // gamma
    double viscosity = 1e-3;      // dynamic viscosity mu [Pa s], Eq. 4
    bool clamp_negative_pressure = true;
    bool no_slip = true; // walls and obstacles hold the fluid by viscosity (else free slip)
    // Monaghan's artificial viscosity alpha between fluid particles (0: none; DualSPHysics uses
    // 0.01): it damps the summation density's pressure noise (docs/PHYSICS.md).
    double artificial_viscosity = 0;
    // The density fluid starts with under continuity (summation ignores it). "rest": rho0;
    // "hydrostatic": fluid at rest starts at the EOS density of the weight of the fluid above it
    // (as DualSPHysics starts).
    enum class InitialDensity { Rest, Hydrostatic } initial_density = InitialDensity::Rest;
    std::vector<FluidBlock> blocks;
  } fluid;

  std::vector<Obstacle> obstacles;

  // [knit]: material (whole fabric, split over the three layers) and its time stepping.
  struct Knit {
    double thickness = 0.002;    // distance between layer 1 and layer 3 [m]
    double mass_per_area = 0.25; // [kg/m^2]
    double stretch = 100.0;      // in-plane tensile modulus [N/m] (force per width per strain)
    double shear = 10.0;         // in-plane shear modulus [N/m]
    double bend = 1.0;           // modulus of the skip-one bend springs [N/m]
    double compression = 5000.0; // through-thickness compression modulus [Pa]
    double layer_shear = 2000.0; // through-thickness shear modulus [Pa] (diagonal springs)
    double damping_ratio = 0.1;  // of every spring, relative to critical
    double contact_radius = 0;   // distance kept from solids [m]; 0: thickness / 2
    double friction = 0.4;       // Coulomb coefficient against solids
    int substeps = 1;            // knit steps per fluid step
    double spring_factor = 0.5;  // dt_knit <= spring_factor * sqrt(m / sum k)
    // Self-collision (DEM between knit points far apart on the rest mesh, Eq. 7 and 8).
    bool self_collision = true;
    double self_radius = 0;    // R [m]; 0: half the longest in-plane spacing (no gaps in a sheet)
    double self_stiffness = 0; // k [N/m]; 0: the stiffest spring of the mesh
    double self_friction = -1; // mu; < 0: the same as `friction`
    int yarn_samples = 4;      // Catmull-Rom points per bonding-point span in snapshots; 0: none
    std::vector<KnitPiece> pieces;
    std::vector<KnitPin> pins;
    double radius() const { return contact_radius > 0 ? contact_radius : 0.5 * thickness; }
  } knit;

  /// Knit-fluid contact (module "contact": DEM, Eq. 7 and 8).
  struct Coupling {
    double fluid_radius = 0; // R_fluid [m]; 0: half the fluid spacing
    double knit_radius = 0;  // R_knit [m]; 0: the knit's contact radius
    double stiffness = 0;    // k [N/m]; 0: stops a fluid particle at c/10 within half the reach
    // The fluid spacing whose particle the default stiffness stops (0: the fluid's own). The
    // preview preset sets the scene's as written: its particles, 8 times heavier, would take a
    // contact ~3.6 times stiffer and halve the knit's substep (the pour's preview planned 1.9
    // times production's steps); they go deeper into the reach instead.
    double stiffness_spacing = 0;
    double damping_ratio = 0.5;
    double friction = 0.3;
    // The tunnelling guard (P8): fluid whose step crosses a face of the knit's sheet goes back
    // to its side and meets the face inelastically (the knit takes the reaction). auto: on with
    // contact alone and with the conserving absorption (fluid reaches the other side only as
    // absorbed fluid and drops); off with the paper's capillary model, whose suction draws the
    // fluid into the fabric's thickness (the guard's faces would hold it out; it also costs the
    // pour 44% on the GPU).
    enum class SheetGuard { Auto, On, Off } sheet_guard = SheetGuard::Auto;
  } coupling;

  /// The porous knit (module "capillary": Eq. 9-12).
  enum class AbsorptionModel { Paper, Conserving };
  struct Capillary {
    // paper: saturation from the fluid around each knit point (Eq. 9), fluid stays particles;
    // conserving: particles touching the fabric are absorbed into it, the absorbed fluid moves
    // by Darcy's law and drips from points holding more than emit_saturation of their capacity.
    AbsorptionModel model = AbsorptionModel::Paper;
    double emit_saturation = 1.0;
    double porosity = 0.8;      // phi: void fraction of the knit's volume
    double permeability = 1e-9; // kappa [m^2]
    double sigma = 0.072;       // sigma [N/m] (water's surface tension)
  } capillary;

  // [parallel]: how the domain is shared out among MPI ranks (DESIGN §6; domain/Decomposition).
  struct Parallel {
    int block_cells = 4; // block edge, in fluid ghost widths (support + skin; RankLayout)
    // Re-partition when the slowest rank's compute time over the mean passes `imbalance`,
    // measured over every `check_every` steps.
    double imbalance = 1.1;
    int check_every = 100;
    // A re-partition must pay for itself: the time the imbalance loses (the slowest rank's
    // compute over the mean, a check's interval) times the intervals the last re-partition held
    // must reach what the last re-partition cost, and the particles' counts must be off balance
    // by more than twice METIS's allowance (false: at every check past `imbalance`).
    bool payback = true;
    // How the ranks' messages move: "auto" (NCCL between device buffers when every rank has a
    // GPU of its own; CUDA IPC, device to device, when ranks of one node share GPUs; else MPI
    // through host memory), "mpi", "nccl" or "ipc" (an error where it cannot run).
    enum class Transport { Auto, Mpi, Nccl, Ipc } transport = Transport::Auto;
    // The passes whose results refresh ghosts compute the rows their peers receive first, then
    // the rest while the exchange is in flight (false: all rows, then the exchange).
    bool overlap = true;
  } parallel;

  // [render]: how `knitflow render` draws the run (P6); its command line overrides the size and
  // the fluid's look. Colours are linear RGB in [0, 1].
  struct Render {
    int width = 1280, height = 720;
    // The camera: eye and target both given, or neither (a view framing the first frame).
    bool camera = false;
    Vec3d eye{0, 0, 0}, target{0, 0, 0};
    double fov = 35;  // vertical, degrees
    double orbit = 0; // degrees a simulated second the eye turns about the target's vertical
    Vec3d light{0.4, -0.5, 0.75}; // toward the light
    double ambient = 0.25, highlights = 0.25;
    Vec3d background{1, 1, 1}, fluid_colour{0.20, 0.45, 0.85}, knit_colour{0.85, 0.55, 0.25};
    double wet_darkening = 0.15; // alpha in C' = C (1 - alpha sqrt(s))
    enum class Fluid { Surface, Spheres } fluid = Fluid::Surface;
    enum class SurfaceField { Weighted, Naive } surface = SurfaceField::Weighted;
    // The surface's grid cell over the fluid's spacing: coarser draws a preview sooner (the
    // field's work goes as its cube) and smooths away detail under a cell.
    double surface_cell = 0.5;
    bool boundary = false;                                // the walls' particles
    enum class Knit { Yarns, Points } knit = Knit::Yarns; // tubes along the yarns, or spheres
    double yarn_radius = 0; // [m]; 0: a fifth of the spacing of the knit's points in a layer
    // The yarns drawn volumetrically from a lumislice (plies of fibres twisted, fuzz about
    // them, blended back to front: render/VolumeYarns) in yarn_slices quads a segment; false:
    // lit tubes.
    bool yarn_volume = true;
    int yarn_plies = 3, yarn_fuzz = 40, yarn_slices = 4;
    // A piece of yarn under yarn_detail_pixels on screen: one quad, the lumislice seen whole,
    // short straight runs of segments merged; 0: every segment its yarn_slices.
    double yarn_detail_pixels = 12;
    bool shadows = true; // cascaded shadow maps of the light
    bool floor = true;   // a floor at the domain's bottom, receiving the shadows
    // The domain's walls that hold the fluid (a tank's sides) drawn from inside: those between
    // the camera and the fluid turn their backs to it and are not drawn.
    bool tank = true;
    bool reflections = true; // the fluid's surface mirrors a sky (Fresnel)
    // ... and the scene around it: a cube map of that many texels a side (0: the sky alone)
    int environment_map = 256;
    // The fluid's surface as translucent water: the scene behind it seen through it, refracted
    // by refractive_index and absorbed so that fluid_colour is the tint of absorption_depth
    // metres of water; false: opaque in fluid_colour.
    bool refraction = true;
    double refractive_index = 1.333;
    double absorption_depth = 0.5; // [m]
    // The fluid's surface and the yarns' tubes built on the GPU (GL compute and vertex
    // shaders); false: on the host (the reference, for a GL without them).
    bool gpu_geometry = true;
  } render;

  bool has(Module m) const {
    for (Module x : modules)
      if (x == m)
        return true;
    return false;
  }
  double support_radius() const { return fluid.spacing * fluid.support; }
};

/// Reads, validates and returns a scene. overrides are "dotted.key=value" strings (--set),
/// the value written in TOML syntax. Throws SceneError("FILE:LINE: key 'K': expected ..., got
/// ...").
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});
/// Same, from text; source_name stands in for the file name in messages.
Scene parse_scene(const std::string& text, const std::string& source_name,
                  const std::vector<std::string>& overrides = {});
/// Same, the files it names relative to files_dir (a snapshot's copy of a run's scene: the
/// folder of the file the run read).
Scene parse_scene(const std::string& text, const std::string& source_name,
                  const std::vector<std::string>& overrides, const std::string& files_dir);

/// Every key a [render] table may hold (scenes/pour.toml shows each).
std::span<const std::string_view> render_table_keys();

/// What a [solver] quality preset sets: the fluid's spacing scaled, and the settings it names
/// (unset: the scene's). Chosen from P7's Pareto fronts (docs/VALIDATION.md, where each
/// preset's error and cost on the reference cases are stated).
struct QualityPreset {
  double spacing_scale = 1;
  double sound_speed_scale = 1; // the fluid's speed of sound (the EOS's stiffness c^2) scaled
  std::optional<double> cfl;
  std::optional<DensityModel> density;
  std::optional<Scene::Solver::NeighbourLists> neighbour_list;
  std::optional<Precision> precision;
  // The knit-fluid contact's default stiffness kept at the scene's own spacing (see
  // Scene::Coupling::stiffness_spacing).
  bool contact_at_scene_spacing = false;
};
QualityPreset quality_preset(Scene::Solver::Quality q);
std::string to_string(Scene::Solver::Quality q);

std::string to_string(KernelType k);
std::string to_string(EosType e);
std::string to_string(Module m);
std::string to_string(ObstacleShape s);
std::string to_string(KnitShape s);

} // namespace kf
