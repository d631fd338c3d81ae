#pragma once
// A snapshot to a picture: the fluid as its surface (or spheres), the knit as tubes along its
// yarns (or its points' spheres), darkened where wet, C' = C (1 - alpha sqrt(s)) (paper §6),
// optionally the boundary's spheres, the scene's obstacles beside them, shadows of the light on a
// floor, from a camera; the fluid's surface opaque or translucent water (refracting, absorbing:
// WaterLayers); the yarns volumetric, from a lumislice (VolumeYarns).
#include "io/Frame.hpp"
#include "io/PngImage.hpp"
#include "render/Camera.hpp"
#include "render/EglContext.hpp"
#include "render/EnvironmentMap.hpp"
#include "render/FluidSurface.hpp"
#include "render/GpuTimer.hpp"
#include "render/MeshRenderer.hpp"
#include "render/OffscreenTarget.hpp"
#include "render/ShadowMaps.hpp"
#include "render/SpaceSplit.hpp"
#include "render/SphereRenderer.hpp"
#include "render/SurfaceCompute.hpp"
#include "render/TubeRenderer.hpp"
#include "render/VolumeYarns.hpp"
#include "render/WaterLayers.hpp"
#include "render/YarnTubes.hpp"

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace kf::render {

struct SnapshotStyle {
  int width = 1280, height = 720;
  bool boundary = false;       // draw the walls' particles (they hide what is inside a tank)
  double wet_darkening = 0.15; // alpha in C' = C (1 - alpha sqrt(s))
  glm::vec4 fluid{0.20f, 0.45f, 0.85f, 1.0f}, knit{0.85f, 0.55f, 0.25f, 1.0f},
      boundary_colour{0.6f, 0.6f, 0.6f, 1.0f}, background{1.0f, 1.0f, 1.0f, 1.0f};
  std::vector<Sphere> obstacles; // solid spheres of the scene, drawn as they are
  // The scene's other solids (boxes, OBJ meshes: closed, seen from any side) and planes (seen
  // only from their fluid's side: a tank's walls do not hide what is in it), in obstacle_colour.
  SurfaceMesh solids, planes;
  // Moving obstacles (a scene's prescribed translation from t = 0): a velocity a sphere of
  // `obstacles` and a vertex of `solids` and of `planes` (empty: all still); a frame at time t
  // draws them moved by velocity t, as the run moved them.
  std::vector<glm::vec3> obstacle_velocity, solid_velocity, plane_velocity;
  // The walls that hold the fluid, wound to face in (box_inside): seen from inside only, so
  // those between the camera and the fluid are not drawn; in floor_colour, receiving shadows
  // but casting none (the light's side of a tank would darken everything in it).
  SurfaceMesh tank;
  glm::vec4 obstacle_colour{0.55f, 0.57f, 0.60f, 1.0f};
  Lighting lighting;
  // The fluid as its surface (marching cubes over the weighted field, FluidSurface) or, off, as
  // the particles' spheres.
  bool fluid_surface = true;
  SurfaceField surface_field = SurfaceField::Weighted;
  double surface_cell = SurfaceOptions{}.cell; // the surface's grid cell over the spacing
  // The surface mirrors a sky over a grey ground by Fresnel's share (Schlick, F0 = 0.02), and
  // with environment_size > 0 the scene without the fluid before it: a cube map of that many
  // texels a side drawn from the fluid's centre (the knit as its points' spheres there: at a
  // cube map's resolution a yarn is under a texel).
  bool fluid_reflection = false;
  int environment_size = 0;
  // The surface as translucent water (WaterLayers): what lies behind seen through it, refracted
  // (refractive_index) and absorbed so that `fluid` is the tint of absorption_depth metres of
  // it; off, opaque in `fluid`'s colour, lit.
  bool fluid_translucent = false;
  float refractive_index = 1.333f;
  double absorption_depth = 0.5;
  // The knit as tubes along the snapshot's yarns (where it holds a yarn phase) or, off, as its
  // mass points' spheres; a yarn's radius [m], 0: a fifth of the spacing of the knit's points in
  // a layer (the paper's pour: 1.1 mm for 5.5 mm stitches).
  bool knit_yarns = true;
  double yarn_radius = 0;
  // The yarns drawn volumetrically from a lumislice (VolumeYarns: fibres, plies, fuzz, blended
  // back to front), the tubes giving their depth and shadows; off, as lit tubes. Needs the
  // yarns' geometry on the GPU.
  bool knit_volume = true;
  LumisliceSpec lumislice;
  int yarn_slices = 4; // quads a segment, 1..4: the most
  // The level of detail: a piece of yarn under yarn_detail_pixels on screen is one quad facing
  // the eye, shaded from the lumislice seen whole, short straight runs of segments merged; 0:
  // every segment its yarn_slices.
  double yarn_detail_pixels = 12;
  // The surface's field and marching cubes as GL compute passes (SurfaceCompute) and the tubes'
  // rings in a vertex shader (TubeRenderer), llvmpipe running them where there is no GPU; off,
  // both built on the host (FluidSurface, yarn_tubes: the references) and uploaded.
  bool geometry_on_gpu = true;
  // Cascaded shadow maps of the light on everything drawn, and a floor (a square under the frame
  // at floor_z; NaN: the frame's lowest point) that receives them.
  bool shadows = false;
  // Texels a side a cascade; 0: twice the picture's larger side, within 256..2048.
  int shadow_resolution = 0, shadow_cascades = 3;
  bool floor = false;
  double floor_z = std::numeric_limits<double>::quiet_NaN();
  glm::vec4 floor_colour{0.80f, 0.80f, 0.78f, 1.0f};
};

/// Typical distance between neighbouring points: the median, over up to 256 of them spread
/// through the list, of the distance to the nearest other point (brute force: 256 x n).
double typical_spacing(const std::vector<glm::dvec3>& points);
/// Its parts, for points spread over ranks: the indices of the samples among n points; the
/// least squared distance (> 0) from each sample (its index sample_index[s]) to `points`,
/// which are points first.. of the n, folded into best[s]; the median of the square roots of
/// the finite ones (0 without any).
std::vector<std::size_t> spacing_samples(std::size_t n);
void nearest_to_samples(const std::vector<glm::dvec3>& sample,
                        const std::vector<std::size_t>& sample_index,
                        const std::vector<glm::dvec3>& points, std::size_t first,
                        std::vector<double>& best);
double median_spacing(const std::vector<double>& best);

/// A phase's positions ("position", 3 components, float or double); empty when the frame lacks
/// the phase.
std::vector<glm::dvec3> phase_positions(const io::Frame& frame, const std::string& phase);

class SnapshotRenderer {
public:
  /// Opens a headless context (EglContext(cuda_device)) and a target of style's size.
  explicit SnapshotRenderer(const SnapshotStyle& style, int cuda_device = -1);

  /// The box of what `frame` shows (its drawn phases and the obstacles); a kf::Error when empty.
  std::pair<glm::dvec3, glm::dvec3> frame_box(const io::Frame& frame) const;
  /// The camera framing it.
  Camera frame_camera(const io::Frame& frame) const;
  /// One camera for a film: framing the first and the last frame's boxes together (a dam
  /// break's column and the tank it spreads over, a knit above a ball and draped on it), and
  /// the floor laid under both from then on, where it followed each frame's box (and jumped).
  /// `tank`, where given, too: the box a fluid is walled in on every side (it may run up a wall
  /// and splash to the lid between the two frames).
  Camera film_camera(const io::Frame& first, const io::Frame& last,
                     const std::optional<std::pair<glm::dvec3, glm::dvec3>>& tank = {});
  /// In a sort-last frame each rank draws only its part's casters into the shadow maps; this
  /// makes them every rank's nearest (an allreduce of the minimum over the ranks drawing the
  /// frame) before they are looked up. Unset, a part's shadows come from its own casters only.
  void set_shadow_combiner(std::function<void(std::vector<float>&)> combine) {
    combine_shadows_ = std::move(combine);
  }
  /// Draws the frame from `camera`. Sphere radii: half the typical spacing of each phase's
  /// points (knit: 0.6 of it, so a sheet closes), taken from the first frame drawn and kept.
  /// With `only`, just the particles and obstacles whose centres lie in it (sort-last rendering:
  /// this rank's part of the frame, composited by depth with the others').
  io::RgbaImage draw(const io::Frame& frame, const Camera& camera, const Region* only = nullptr);
  /// The last draw's depth in [0, 1] (1: nothing drawn), a float a pixel, the top row first:
  /// the opaque scene's where the water is translucent.
  std::vector<float> depth() const { return target_.read_depth(); }
  /// Whether the fluid is drawn as translucent water: a part of a frame is then composited as
  /// layers (draw_layers, keep_nearer of LayeredPixel) and the composite resolved.
  bool translucent() const { return style_.fluid_translucent && style_.fluid_surface; }
  /// A part of a frame (sort-last) as its layers, translucent water only: the opaque scene's
  /// colour and depth and the water's, a record a pixel (WaterLayers::read's order: GL's, the
  /// bottom row first).
  std::vector<LayeredPixel> draw_layers(const io::Frame& frame, const Camera& camera,
                                        const Region* only);
  /// Whether a sort-last part draws this frame's yarns as a layer of their own
  /// (draw_yarn_layer): volumetric yarns are translucent, blended over what lies behind them.
  bool yarn_layer(const io::Frame& frame) const { return volume_yarns(frame); }
  /// A part's volumetric yarns, after its draw (or draw_layers) of the same frame from the same
  /// camera, once the opaque scene's composite depth is known (`opaque_depth`, a value a pixel,
  /// the top row first: every part's, comm::allgather_strips): the slices of the yarns within
  /// reach of `only`, cut at its faces, blended back to front over transparent black where
  /// that scene does not hide them, and their cores' depth (YarnPixel, the image's order). The
  /// parts' layers folded front to back (yarns_over, in visibility_order) are the whole
  /// frame's yarns.
  std::vector<YarnPixel> draw_yarn_layer(const Camera& camera, const Region& only,
                                         const std::vector<float>& opaque_depth);
  /// The picture of a composite of parts' layers seen from `camera` (the water resolved), the
  /// composite of their yarns' layers (none: empty; the image's order, top row first, unlike
  /// the layers') over its opaque scene first.
  io::RgbaImage resolve(std::vector<LayeredPixel> layers, const std::vector<YarnPixel>& yarns,
                        const Camera& camera);
  /// The picture of a composite of opaque parts (DepthPixel, the image's order) with the
  /// composite of their yarns' layers (none: empty) over it.
  io::RgbaImage composite_picture(std::vector<DepthPixel> pixels,
                                  const std::vector<YarnPixel>& yarns) const;
  /// The points a k-d split of this frame shares out: the drawn phases' positions (without
  /// the fluid's: the others', for a frame whose fluid is split over ranks).
  std::vector<glm::dvec3> drawn_points(const io::Frame& frame, bool with_fluid = true) const;
  /// The whole frame's fluid, for frames that hold a part of it (a rank's region and a halo,
  /// read as its share of the snapshot; the other phases whole): its box and typical spacing,
  /// so the surface's grid, the frame's box, the shadows' and the spheres' radius are the
  /// whole frame's. Unset (nullopt), they come from the frame drawn.
  struct WholeFluid {
    glm::dvec3 lo{0}, hi{0};
    double spacing = 0; // typical_spacing of all its points
    bool empty = true;
  };
  void set_whole_fluid(std::optional<WholeFluid> whole);
  /// Whether the fluid's spacing is known (from the first frame drawn or set_whole_fluid): a
  /// later WholeFluid's spacing is not used.
  bool knows_fluid_spacing() const { return fluid_r_.has_value(); }
  /// How far past a region a part's drawing reads the fluid (the surface's kernel reach and
  /// the cells about the region its field fills), for the whole fluid `whole`: 0 for spheres.
  double fluid_halo(const WholeFluid& whole) const;
  std::size_t last_spheres() const { return last_spheres_; }
  std::size_t last_triangles() const { return last_triangles_; }
  /// The yarn segments the last draw built (a part's: those within reach of its region).
  std::size_t last_yarn_segments() const { return tubes_.segments(); }
  /// Seconds the last draw spent on the fluid's surface (field and marching cubes, their
  /// triangles ready to draw).
  double last_surface_seconds() const { return last_surface_seconds_; }
  /// Seconds the last draw spent on the yarns' frames (host; the GPU builds the rings).
  double last_yarn_seconds() const { return last_yarn_seconds_; }
  /// The last draw's passes and their GPU seconds (GL timestamps): the surface's field and
  /// cubes, the yarns' frames, the other uploads, the shadow maps, the picture, its read-back.
  const std::vector<std::pair<std::string, double>>& last_passes() const { return last_passes_; }
  int width() const { return style_.width; }
  const ContextInfo& context() const { return context_.info(); }

private:
  /// The frame's fluid surface (none when the fluid is drawn as spheres) into meshes_: started
  /// (on the GPU: its passes sent), then finished (their counts waited for), its triangles; and
  /// the knit's tubes (none without a yarn phase or with the knit as points) into tubes_, their
  /// triangles; both timed; with `only`, its part.
  void start_surface(const io::Frame& frame, const Region* only);
  std::size_t finish_surface();
  std::size_t knit_tubes(const io::Frame& frame, const Region* only);
  bool has_yarns(const io::Frame& frame) const;
  /// The obstacles where they stand at `time` (moved by their velocities).
  struct Placed {
    std::vector<Sphere> spheres;
    SurfaceMesh solids, planes;
  };
  Placed placed(double time) const;
  /// A phase's points as spheres into `list` (with `only`, those in it): radius share x the
  /// spacing of its points in a layer (taken once, kept in `radius`), colour darkened by the
  /// saturation where `wet`.
  void add_spheres(std::vector<Sphere>& list, const io::Frame& frame, const std::string& phase,
                   std::optional<double>& radius, double share, const glm::vec4& colour, bool wet,
                   const Region* only) const;
  /// frame_box with the obstacles placed already.
  std::pair<glm::dvec3, glm::dvec3> box_of(const io::Frame& frame, const Placed& at) const;
  /// The same, empty where the frame holds nothing to draw (box_of's error).
  std::optional<std::pair<glm::dvec3, glm::dvec3>> content_box(const io::Frame& frame,
                                                               const Placed& at) const;
  /// Everything uploaded, through `view`: the picture's pass (the floor, the water's reflection,
  /// planes one-sided) or a shadow map's (the casters).
  void draw_scene(const ViewMatrices& view, const Lighting& light, bool picture);
  /// Everything of the frame drawn into target_ (and the water's layers where translucent);
  /// the public draws read or resolve it.
  void render(const io::Frame& frame, const Camera& camera, const Region* only);
  /// Whether a frame's yarns are drawn volumetrically (in a sort-last frame: after the composite).
  bool volume_yarns(const io::Frame& frame) const {
    return style_.knit_volume && style_.geometry_on_gpu && has_yarns(frame);
  }
  /// The built tubes' slices, ordered, blended over `target`, then their cores' depth;
  /// with `clip`, cut at its faces.
  void draw_yarn_slices(const ViewMatrices& view, const Lighting& lighting,
                        const OffscreenTarget& target, const Region* clip = nullptr);
  /// The reach of a part's yarns past its region: the slices' half width, wet.
  double yarn_reach() const;
  /// The water's layers resolved into picture_ and read back.
  io::RgbaImage resolved(const Camera& camera);
  WaterOptics optics() const;
  /// The cascades fitted to the camera and the box, the casters drawn into them; a part's maps
  /// reduced over the ranks (set_shadow_combiner).
  void draw_shadow_maps(const Camera& camera, double aspect, const glm::dvec3& lo,
                        const glm::dvec3& hi, bool part);
  /// The scene without the fluid into the environment map, from the fluid's centre: the whole
  /// frame's obstacles, knit points, solids, planes and floor on every rank (a few thousand
  /// texels' worth: no composite needed); 0 when the surface mirrors the sky alone.
  unsigned draw_environment(const io::Frame& frame, const Placed& at, const glm::dvec3& lo,
                            const glm::dvec3& hi, const Lighting& lighting);

  SnapshotStyle style_;
  EglContext context_;
  OffscreenTarget target_;
  SphereRenderer spheres_;
  MeshRenderer meshes_, yarn_meshes_, floor_mesh_, solid_mesh_, plane_mesh_, tank_mesh_;
  TubeRenderer tubes_;
  std::unique_ptr<VolumeYarns> volume_;
  bool sort_on_cuda_ = false;
  /// Whether this frame's yarns are drawn volumetrically (their tubes built on the GPU).
  bool volumetric() const {
    return style_.knit_volume && style_.geometry_on_gpu && tubes_.segments() > 0;
  }
  std::unique_ptr<ShadowMaps> shadows_;
  std::unique_ptr<WaterLayers> water_;
  std::unique_ptr<EnvironmentMap> environment_;
  SphereRenderer environment_spheres_;
  glm::dvec3 fluid_centre_{0.0};
  unsigned environment_texture_ = 0;            // this frame's, 0: the sky alone
  std::unique_ptr<OffscreenTarget> picture_;    // the resolve's
  std::unique_ptr<OffscreenTarget> yarn_layer_; // a part's yarns (half floats)
  std::unique_ptr<SurfaceCompute> surface_compute_;
  GpuTimer timer_;
  std::vector<std::pair<std::string, double>> last_passes_;
  std::function<void(std::vector<float>&)> combine_shadows_;
  std::optional<double> fluid_r_, knit_r_, boundary_r_, yarn_r_;
  std::optional<WholeFluid> whole_fluid_;
  std::optional<std::pair<glm::dvec3, glm::dvec3>> stage_; // the film's box, the floor's
  SurfaceOptions surface_options() const;
  std::size_t last_spheres_ = 0, last_triangles_ = 0;
  double last_surface_seconds_ = 0, last_yarn_seconds_ = 0;
  bool surface_started_ = false;
  std::size_t surface_triangles_ = 0;
};

} // namespace kf::render
