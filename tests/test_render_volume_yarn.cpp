// The volumetric yarns (render/VolumeYarns, P6): slices drawn back to front (their distances
// from the eye, read back in drawing order, never grow; the CUDA sort through CUDA-GL interop
// gives the host sort's order); a straight yarn seen side on: every pixel's opacity is the
// Beer-Lambert quadrature over the slices the pixel's ray crosses, computed here from the
// lumislice's texture, its twist and the slices' planes; the wet yarn's darkening measured
// on the picture, 1 - alpha sqrt(s); and the level of detail (fewer slices and merged segments
// where the yarn is small on screen) against every segment's full slices on a knit-like picture.
#include "kernels/exec/Backend.hpp"
#include "render/EglContext.hpp"
#include "render/SnapshotRender.hpp"
#include "render/TubeRenderer.hpp"
#include "render/VolumeYarns.hpp"
#include "render/YarnTubes.hpp"

#include <gtest/gtest.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace kf;

namespace {

/// Straight yarns along x from x0 to -x0 at the points (y, z), 41 points each, saturation s.
io::Frame straight_yarns(const std::vector<glm::vec2>& at, float x0, float s) {
  std::vector<float> x, sat;
  std::vector<std::uint32_t> seg;
  const int n = 41;
  for (const glm::vec2& p : at)
    for (int i = 0; i < n; ++i) {
      const auto k = std::uint32_t(x.size() / 3);
      x.insert(x.end(), {x0 - 2 * x0 * float(i) / float(n - 1), p.x, p.y});
      seg.insert(seg.end(), {k, i + 1 < n ? k + 1 : k});
      sat.push_back(s);
    }
  io::Frame f;
  f.phases.push_back({"yarn",
                      {io::Field::from("position", x, 3), io::Field::from("segment", seg, 2),
                       io::Field::from("saturation", sat, 1)}});
  return f;
}

/// Wavy yarns along x (a row of loops seen side on, like a knit's courses), rows apart in y:
/// z = amplitude sin(2 pi x / wavelength), a point every 1.25 mm.
io::Frame wavy_yarns(int rows, float spacing) {
  std::vector<float> x, sat;
  std::vector<std::uint32_t> seg;
  const int n = 161;
  for (int row = 0; row < rows; ++row)
    for (int i = 0; i < n; ++i) {
      const auto k = std::uint32_t(x.size() / 3);
      const float px = -0.1f + 0.2f * float(i) / float(n - 1);
      x.insert(x.end(), {px, spacing * (float(row) - 0.5f * float(rows - 1)),
                         0.004f * std::sin(2 * float(M_PI) * px / 0.02f + float(row))});
      seg.insert(seg.end(), {k, i + 1 < n ? k + 1 : k});
      sat.push_back(0.0f);
    }
  io::Frame f;
  f.phases.push_back({"yarn",
                      {io::Field::from("position", x, 3), io::Field::from("segment", seg, 2),
                       io::Field::from("saturation", sat, 1)}});
  return f;
}

render::YarnPolylines helix() {
  render::YarnPolylines y;
  for (std::uint32_t i = 0; i < 400; ++i) {
    const double a = 0.05 * i;
    y.x.push_back({0.1 * std::cos(a), 0.1 * std::sin(a), 0.004 * a});
    y.segment.push_back({i, i + 1 < 400 ? i + 1 : i});
    y.s.push_back(0.0);
  }
  return y;
}

/// The helix's tubes (radius 1 cm) built on the GPU, and the camera looking at it.
struct HelixScene {
  render::TubeRenderer tubes;
  render::YarnStyle style;
  render::Camera camera;
  HelixScene() {
    style.radius = 0.01;
    tubes.build(render::yarn_points(helix()), style);
    camera.eye = {0.35, -0.35, 0.3};
    camera.target = {0, 0, 0.04};
  }
  render::ViewMatrices view() const { return render::ViewMatrices::of(camera, 4.0 / 3.0); }
};

/// The ray through pixel (col, row) (row 0 at the top): origin and unit direction.
std::pair<glm::dvec3, glm::dvec3> pixel_ray(const render::Camera& cam, int w, int h, int col,
                                            int row) {
  const glm::dmat4 inv = glm::inverse(glm::dmat4(cam.projection(double(w) / h) * cam.view()));
  const double x = (col + 0.5) / w * 2 - 1, y = 1 - (row + 0.5) / h * 2;
  glm::dvec4 a = inv * glm::dvec4(x, y, -1, 1), b = inv * glm::dvec4(x, y, 1, 1);
  a /= a.w;
  b /= b.w;
  return {glm::dvec3(a), glm::normalize(glm::dvec3(b - a))};
}

} // namespace

TEST(RenderVolumeYarn, SlicesAreDrawnBackToFront) {
  render::EglContext context;
  const HelixScene h;
  const render::Camera& cam = h.camera;
  double lo = 1e9, hi = 0;
  for (const glm::dvec3& x : helix().x) {
    lo = std::min(lo, glm::length(x - cam.eye));
    hi = std::max(hi, glm::length(x - cam.eye));
  }
  // Every segment its 4 slices, then the level of detail at 240 pixels high (the helix's yarn
  // 14 pixels wide, 4 slices a piece; where it is narrower, one; runs of 2 and more merged).
  for (const double detail_pixels : {0.0, 6.0}) {
    render::VolumeYarns volume({}, false, 4, detail_pixels);
    volume.order(h.tubes, h.view(), h.style.radius, {}, 240);
    const std::vector<float> d = volume.drawn_distances();
    if (detail_pixels == 0) {
      ASSERT_EQ(d.size(), 399u * 4u);
    } else {
      std::printf("level of detail: %zu slices for 399 segments\n", d.size());
      EXPECT_LT(d.size(), 399u * 3u); // measured 880: merged runs
      EXPECT_GE(d.size(), 399u / 8u); // a piece is at most 8 segments with a slice or more
    }
    for (std::size_t q = 1; q < d.size(); ++q)
      ASSERT_LE(d[q], d[q - 1]) << "slice " << q << " drawn after a nearer one";
    // The slices lie about the yarn: between the nearest and farthest point of its tube.
    const double reach = h.style.radius * volume.lumislice().spec.reach();
    EXPECT_GE(d.back(), lo - reach);
    EXPECT_LE(d.front(), hi + reach);
  }
}

TEST(RenderVolumeYarn, TheGpusSortIsTheHostsOrder) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device: the host's sort is the only one here";
  const int device = exec::cuda_select_device(0);
  render::EglContext context(device);
  if (context.info().software)
    GTEST_SKIP() << "the GL context is not the GPU's";
  const HelixScene h;
  render::VolumeYarns host({}, false, 4, 6), gpu({}, true, 4, 6);
  ASSERT_TRUE(gpu.sorts_on_cuda());
  host.order(h.tubes, h.view(), h.style.radius, {}, 240);
  gpu.order(h.tubes, h.view(), h.style.radius, {}, 240);
  EXPECT_EQ(gpu.drawn_distances(), host.drawn_distances());
}

namespace {

/// A straight white yarn of radius 3 cm along x from x0 to -x0, seen side on from 0.25 m (320 x
/// 240, black background, ambient light only), and each pixel's value against a reference
/// along its ray: (value, transmitted, whether the ray stays away from the yarn's ends).
struct SideView {
  static constexpr double radius = 0.03;
  static constexpr float x0 = -0.2f;
  render::SnapshotStyle style;
  render::Camera cam;
  SideView() {
    style.width = 320;
    style.height = 240;
    style.yarn_radius = radius;
    style.knit = {1, 1, 1, 1};
    style.background = {0, 0, 0, 1};
    style.lighting.ambient = 1.0f;
    cam.eye = {0, -0.25, 0};
    cam.target = {0, 0, 0};
    cam.up = {0, 0, 1};
  }
  struct Ray {
    double value = 0, transmitted = 1;
    bool inside = true;
  };
  struct Agreement {
    int compared = 0, worst = 0, opaque = 0;
    double mean = 0;
  };
  template <typename Reference>
  Agreement compare(const char* name, Reference&& along) const {
    render::SnapshotRenderer r(style);
    const io::RgbaImage img = r.draw(straight_yarns({{0.0f, 0.0f}}, x0, 0.0f), cam);
    Agreement g;
    double sum = 0;
    for (int row = 0; row < style.height; ++row)
      for (int col = 0; col < style.width; ++col) {
        const auto [eye, dir] = pixel_ray(cam, style.width, style.height, col, row);
        const Ray ray = along(eye, dir);
        if (!ray.inside)
          continue;
        const int want = int(std::lround(255 * ray.value));
        const int got = img.pixels[4 * (std::size_t(row) * style.width + col)];
        g.worst = std::max(g.worst, std::abs(got - want));
        sum += std::abs(got - want);
        g.opaque += ray.transmitted < 0.02;
        ++g.compared;
      }
    g.mean = sum / std::max(g.compared, 1);
    std::printf("%s: %d pixels, %d nearly opaque; off by %d levels at worst, %.3f on average\n",
                name, g.compared, g.opaque, g.worst, g.mean);
    return g;
  }
};

} // namespace

TEST(RenderVolumeYarn, ASideViewsOpacityIsTheSlicesBeerLambert) {
  // White yarn, black background, ambient light only: a pixel's value is sum_k u_k a_k prod_(j
  // nearer) (1 - a_j) over the slices its ray crosses, a_k = 1 - exp(-sigma d_k path_k), u_k
  // the ambient light's share at the slice's point (the texture's last layer); the yarn close
  // enough that the texture is drawn from its first level: a pixel spans 0.5 texel across the
  // yarn, and the twist turns the section by under 0.6 texel a pixel at its rim (at 0.4 m the
  // two summed past a texel at some pixels, where GPUs took the second level: 33 levels off).
  SideView view;
  view.style.yarn_detail_pixels = 0; // every segment the 4 slices the reference crosses
  const double radius = SideView::radius, x0 = SideView::x0;
  // The reference from the texture as GL holds it (8 bits a texel), sampled bilinearly.
  render::Lumislice s = render::make_lumislice(view.style.lumislice);
  for (auto* field : {&s.density, &s.ambient})
    for (float& d : *field)
      d = std::round(255 * d) / 255;
  const double reach = s.spec.reach(), twist = 2 * M_PI / (s.spec.twist_pitch * radius);
  const int slices = view.style.yarn_slices;
  // The frame along x: r = +z, b = -y (yarn_frames' first normal); the eye looks along +y, so
  // the slices are the stack normal to b, at y = -reach R o_j.
  const auto g = view.compare("side view", [&](const glm::dvec3& eye, const glm::dvec3& dir) {
    SideView::Ray ray;
    for (int j = slices - 1; j >= 0; --j) { // front to back: o_j = 0.75 is the nearest
      const double o = -1 + (2.0 * j + 1) / slices;
      const double t = (-reach * radius * o - eye.y) / dir.y;
      const glm::dvec3 p = eye + t * dir;
      if (p.x < x0 + 0.05 || p.x > -x0 - 0.05) // away from the yarn's ends
        ray.inside = false;
      const double lx = p.z / (reach * radius), ly = o, angle = twist * (p.x - x0);
      const double c = std::cos(angle), sn = std::sin(angle);
      const double qx = c * lx + sn * ly, qy = -sn * lx + c * ly;
      const double d = std::abs(lx) > 1 ? 0 : s.density_at(float(qx * reach), float(qy * reach));
      const double u = s.at(s.ambient.data(), float(qx * reach), float(qy * reach), 1);
      const double path = 2 * reach / slices / std::max(std::abs(dir.y), 0.2);
      const double a = 1 - std::exp(-s.spec.extinction * d * path);
      if (a >= 1.0 / 512) {
        ray.value += ray.transmitted * a * u;
        ray.transmitted *= 1 - a;
      }
    }
    return ray;
  });
  ASSERT_GT(g.compared, 10000);
  EXPECT_GT(g.opaque, 1000) << "the plies' core hides what is behind it";
  // 8-bit texels, GL's bilinear weights (8 bits of a texel on llvmpipe) and the value's 8-bit
  // rounding; where a fibre's edge crosses a pixel, the weights' rounding moves a slice's
  // density by up to a level of the texel's change (measured 3 levels at worst, 0.16 on
  // average, llvmpipe).
  EXPECT_LE(g.worst, 4);
  EXPECT_LT(g.mean, 0.25);
}

TEST(RenderVolumeYarn, ASideViewSeenWholeIsTheSectionsBeerLambert) {
  // The same yarn drawn as quads seen whole (the level of detail's, here at every size): a
  // pixel's value against the Beer-Lambert integral along its ray through the texture, sum_k
  // u_k a_k prod_(j nearer) (1 - a_j) over steps of R / 64 (the texture seen whole took steps of
  // half a texel, 0.022 R, along parallel lines in the section's plane; the quad's corners
  // each their own ray's angle). Untwisted: a ray crossing the yarn obliquely sees the plies
  // turn along it, which the table does not hold (the pitch of 8 R here: 7 levels off on
  // average, 12 at the picture's sides; why the level of detail takes it only where a yarn is
  // small on screen).
  SideView view;
  view.style.yarn_detail_pixels = 1e6; // every piece seen whole
  view.style.lumislice.twist_pitch = 1e6;
  const double radius = SideView::radius, x0 = SideView::x0;
  const render::Lumislice s = render::make_lumislice(view.style.lumislice);
  const double reach = s.spec.reach(), twist = 2 * M_PI / (s.spec.twist_pitch * radius);
  const auto g = view.compare("seen whole", [&](const glm::dvec3& eye, const glm::dvec3& dir) {
    SideView::Ray ray;
    const double dt = radius / 64, t0 = (-reach * radius - eye.y) / dir.y,
                 t1 = (reach * radius - eye.y) / dir.y;
    for (double t = t0 + 0.5 * dt; t < t1; t += dt) {
      const glm::dvec3 p = eye + t * dir;
      if (p.x < x0 + 0.05 || p.x > -x0 - 0.05)
        ray.inside = false;
      const double lx = p.z / radius, ly = -p.y / radius, angle = twist * (p.x - x0);
      const double c = std::cos(angle), sn = std::sin(angle);
      const double qx = c * lx + sn * ly, qy = -sn * lx + c * ly;
      const double a =
          1 - std::exp(-s.spec.extinction * s.density_at(float(qx), float(qy)) * dt / radius);
      ray.value += ray.transmitted * a * s.at(s.ambient.data(), float(qx), float(qy), 1);
      ray.transmitted *= 1 - a;
    }
    return ray;
  });
  ASSERT_GT(g.compared, 10000);
  EXPECT_GT(g.opaque, 1000) << "the plies' core hides what is behind it";
  // The table's 64 offsets and 256 angles, bilinear, at 8 bits, against exact offsets: a sharp
  // fibre's edge magnified 2.7 times (the yarn 170 pixels across) moves a pixel by up to a
  // texel's change (measured 21 levels at worst, 1.29 on average, llvmpipe).
  EXPECT_LE(g.worst, 26);
  EXPECT_LT(g.mean, 1.5);
}

TEST(RenderVolumeYarn, AWetYarnIsDarkerByOneMinusAlphaRootS) {
  // Parallel yarns seen from above, lit, on black: the picture's total luminance at saturation
  // s over that of dry yarns as thick as the wet ones swell (radius (1 + swell s)): the same
  // fibres at the same places, only their colour darkened.
  std::vector<glm::vec2> rows;
  for (int k = -4; k <= 4; ++k)
    rows.push_back({0.03f * float(k), 0.0f});
  const double radius = 0.008, swell = render::YarnStyle{}.swell;
  render::Camera cam;
  cam.eye = {0, 0, 0.5};
  cam.target = {0, 0, 0};
  cam.up = {0, 1, 0};
  auto luminance = [&](double r, float s) {
    render::SnapshotStyle style;
    style.width = 320;
    style.height = 240;
    style.yarn_radius = r;
    style.background = {0, 0, 0, 1};
    render::SnapshotRenderer renderer(style);
    const io::RgbaImage img = renderer.draw(straight_yarns(rows, -0.1f, s), cam);
    double sum = 0;
    std::size_t lit = 0;
    for (std::size_t k = 0; k < img.pixels.size(); k += 4) {
      const std::uint8_t* p = &img.pixels[k];
      sum += 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
      lit += p[0] > 0;
    }
    EXPECT_GT(lit, 5000u) << "the yarns cover too little of the picture";
    return sum;
  };
  for (float s : {0.25f, 1.0f}) {
    const double ratio = luminance(radius, s) / luminance(radius * (1 + swell * s), 0.0f);
    const double want = 1 - render::SnapshotStyle{}.wet_darkening * std::sqrt(double(s));
    std::printf("s = %.2f: luminance ratio %.4f, 1 - alpha sqrt(s) = %.4f\n", s, ratio, want);
    // The 2%: the twist's pitch is the dry radius's, so the thicker dry yarns' fibres turn
    // at other places along them (measured 0.7%; the 8-bit rounding is far under it).
    EXPECT_NEAR(ratio, want, 0.02 * want);
  }
}

TEST(RenderVolumeYarn, TheLevelOfDetailKeepsTheKnitsPicture) {
  // Rows of wavy yarns 3 pixels wide, their segments under a pixel long (the paper's pour at
  // 1080p: 2.8 pixels and 0.4), lit, with shadows, on black: drawn with the level of detail
  // (one quad a piece, seen whole, from the texture's coarse levels; runs of segments merged)
  // against the reference, the same yarns seen whole drawn 8 times larger each way (24 pixels
  // wide: the texture's first levels, no merging) and averaged over each pixel's 64. And 4 slices
  // a segment at both sizes: slices are a quadrature of the line's integral, poor where a slice
  // samples the coverage averaged over many fibres (opacity 1 - exp(-sigma d path) of an average
  // d overstates the average opacity), so their picture changes as it is drawn larger (measured
  // mean 82.5 levels at 1x, 46.2 at 8x); the seen-whole integral's hardly does (43.9 at 1x
  // with merged runs, 46.1 at 8x).
  const io::Frame f = wavy_yarns(12, 0.006f);
  render::Camera cam;
  cam.eye = {0.05, -0.45, 0.3};
  cam.target = {0, 0, 0};
  cam.up = {0, 0, 1};
  const int w = 320, h = 240;
  auto picture = [&](double detail_pixels, int scale) {
    render::SnapshotStyle style;
    style.width = w * scale;
    style.height = h * scale;
    style.yarn_radius = 0.0015;
    style.shadows = true;
    style.shadow_resolution = 1024; // the same shadows at every size
    style.background = {0, 0, 0, 1};
    style.yarn_detail_pixels = detail_pixels;
    render::SnapshotRenderer r(style);
    const io::RgbaImage big = r.draw(f, cam);
    std::vector<double> px(std::size_t(w) * h * 3, 0.0);
    for (int y = 0; y < h * scale; ++y)
      for (int x = 0; x < w * scale; ++x)
        for (int c = 0; c < 3; ++c)
          px[3 * (std::size_t(y / scale) * w + x / scale) + c] +=
              big.pixels[4 * (std::size_t(y) * w * scale + x) + c] / double(scale * scale);
    return px;
  };
  const std::vector<double> reference = picture(1e6, 8);
  auto compare = [&](const std::vector<double>& p, const char* name) {
    double off = 0, want = 0, got = 0;
    std::size_t lit = 0;
    for (std::size_t k = 0; k < p.size(); k += 3) {
      if (reference[k] + reference[k + 1] + reference[k + 2] < 3)
        continue;
      ++lit;
      for (int c = 0; c < 3; ++c) {
        off += std::abs(p[k + c] - reference[k + c]);
        want += reference[k + c];
        got += p[k + c];
      }
    }
    std::printf("%s: %zu pixels lit; mean %.2f levels a channel against the reference's %.2f; "
                "mean |difference| %.2f\n",
                name, lit, got / (3.0 * lit), want / (3.0 * lit), off / (3.0 * lit));
    return std::tuple(got / want, off / (3.0 * lit), lit);
  };
  const auto [ratio, off, lit] =
      compare(picture(render::SnapshotStyle{}.yarn_detail_pixels, 1), "level of detail");
  const auto [slices_ratio, slices_off, slices_lit] = compare(picture(0, 1), "4 slices a segment");
  compare(picture(0, 8), "4 slices a segment, 8x");
  ASSERT_GT(lit, 4000u) << "the yarns cover too little of the picture";
  // Measured 4.7% darker and 7.5 levels a pixel on llvmpipe, 7.1% and 8.2 on the H100 (its
  // texture levels chosen otherwise): the merged runs' chords (a half pixel off the
  // curve at most) and one shadow lookup a piece; the fibres' pattern itself moves a pixel's
  // value by a few levels between sizes.
  EXPECT_NEAR(ratio, 1.0, 0.09);
  EXPECT_LT(off, 10.0);
  EXPECT_LT(off, slices_off / 3) << "the slices came nearer the reference than the level of detail";
}

TEST(RenderVolumeYarn, StitchColoursFromTheYarnsColourField) {
  // Two parallel yarns seen from above, one red and one blue by the snapshot's colour field
  // (a colour chart's), on black, ambient light only: every lit pixel over the red yarn is red
  // (its green and blue nothing), over the blue one blue; volumetric and as tubes (their white
  // highlight off). A yarn
  // without colours (negative) takes the style's knit colour.
  io::Frame f = straight_yarns({{-0.03f, 0.0f}, {0.03f, 0.0f}, {0.0f, 0.0f}}, -0.1f, 0.0f);
  const std::size_t n = f.phases[0].fields[0].count;
  std::vector<float> colour;
  for (std::size_t i = 0; i < n; ++i) {
    const int yarn = int(i / (n / 3));
    colour.insert(colour.end(), yarn == 0   ? std::initializer_list<float>{1, 0, 0}
                                : yarn == 1 ? std::initializer_list<float>{0, 0, 1}
                                            : std::initializer_list<float>{-1, -1, -1});
  }
  f.phases[0].fields.push_back(io::Field::from("colour", colour, 3));
  render::Camera cam;
  cam.eye = {0, 0, 0.4};
  cam.target = {0, 0, 0};
  cam.up = {0, 1, 0};
  for (bool volume : {true, false}) {
    SCOPED_TRACE(volume ? "volumetric" : "tubes");
    render::SnapshotStyle style;
    style.width = 320;
    style.height = 240;
    style.yarn_radius = 0.006;
    style.knit_volume = volume;
    style.knit = {0, 1, 0, 1}; // green: the uncoloured yarn's
    style.background = {0, 0, 0, 1};
    style.lighting.ambient = 1.0f;
    style.lighting.specular = 0.0f; // the tubes' white highlight off
    render::SnapshotRenderer r(style);
    const io::RgbaImage img = r.draw(f, cam);
    std::size_t lit[3] = {0, 0, 0}, wrong = 0;
    for (int row = 0; row < style.height; ++row)
      for (int col = 0; col < style.width; ++col) {
        const std::uint8_t* p = &img.pixels[4 * (std::size_t(row) * style.width + col)];
        if (p[0] + p[1] + p[2] < 8)
          continue;
        // The yarn under the pixel: y = -0.03 (top of the picture: up is +y), 0.03 or 0.
        const auto [eye, dir] = pixel_ray(cam, style.width, style.height, col, row);
        const double y = eye.y + dir.y * (-eye.z / dir.z);
        const int yarn = y > 0.015 ? 1 : (y < -0.015 ? 0 : 2);
        ++lit[yarn];
        const int own = yarn == 0 ? 0 : (yarn == 1 ? 2 : 1);
        for (int c = 0; c < 3; ++c)
          wrong += c != own && p[c] > 0;
      }
    std::printf("%s: %zu / %zu / %zu pixels lit over the red, blue and plain yarns; %zu channels "
                "not theirs\n",
                volume ? "volumetric" : "tubes", lit[0], lit[1], lit[2], wrong);
    EXPECT_GT(lit[0], 2000u);
    EXPECT_GT(lit[1], 2000u);
    EXPECT_GT(lit[2], 2000u);
    EXPECT_EQ(wrong, 0u) << "a yarn's pixels carry another's colour";
  }
}
