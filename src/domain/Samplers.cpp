#include "domain/Samplers.hpp"

#include "domain/RigidShapes.hpp"

#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/SmoothingKernels.hpp"

#include <algorithm>
#include <cmath>

namespace kf {

namespace {

int cells_along(double length, double dp) {
  return std::max(0, static_cast<int>(std::floor(length / dp + 1e-9)));
}

} // namespace

std::vector<Vec3d> sample_fluid_block(const FluidBlock& block, double dp) {
  const Vec3d e = block.max - block.min;
  const int nx = cells_along(e.x, dp), ny = cells_along(e.y, dp), nz = cells_along(e.z, dp);
  std::vector<Vec3d> x;
  x.reserve(static_cast<std::size_t>(nx) * ny * nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        x.push_back(block.min + Vec3d{(i + 0.5) * dp, (j + 0.5) * dp, (k + 0.5) * dp});
  return x;
}

std::vector<Vec3d> sample_fluid(const Scene& scene) {
  std::vector<Vec3d> x;
  for (const auto& b : scene.fluid.blocks) {
    auto p = sample_fluid_block(b, scene.fluid.spacing);
    x.insert(x.end(), p.begin(), p.end());
  }
  return x;
}

double lattice_particle_mass(KernelType kernel, double support, double dp, double rho0) {
  const double h = support * dp;
  const int r = static_cast<int>(std::ceil(support)) + 1;
  double sum = 0;
  with_kernel<double>(kernel, h, [&](auto k) {
    for (int i = -r; i <= r; ++i)
      for (int j = -r; j <= r; ++j)
        for (int l = -r; l <= r; ++l) sum += k.W(dp * std::sqrt(double(i * i + j * j + l * l)));
    return 0;
  });
  return rho0 / sum;
}

BoundarySamples sample_boundaries(const Scene& scene, double dp, double depth) {
  // The lattice of the fluid (aligned with the domain) continued into every solid, one shell of
  // thickness `depth` deep: at rest a flat wall is then an exact mirror of the fluid, and one
  // rule samples walls, boxes, spheres and planes alike.
  const auto shapes = make_rigid_shapes<double>(scene);
  const std::size_t container = scene.obstacles.size(); // index of the walls, if any are closed
  const Vec3d lo = scene.domain.min - Vec3d{depth, depth, depth};
  const Vec3d hi = scene.domain.max + Vec3d{depth, depth, depth};
  const int i0 = static_cast<int>(std::floor((lo.x - scene.domain.min.x) / dp));
  const int j0 = static_cast<int>(std::floor((lo.y - scene.domain.min.y) / dp));
  const int k0 = static_cast<int>(std::floor((lo.z - scene.domain.min.z) / dp));
  const int i1 = static_cast<int>(std::ceil((hi.x - scene.domain.min.x) / dp));
  const int j1 = static_cast<int>(std::ceil((hi.y - scene.domain.min.y) / dp));
  const int k1 = static_cast<int>(std::ceil((hi.z - scene.domain.min.z) / dp));
  BoundarySamples out;
  for (int k = k0; k <= k1; ++k)
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Vec3d x = scene.domain.min + Vec3d{(i + 0.5) * dp, (j + 0.5) * dp, (k + 0.5) * dp};
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          Vec3d n;
          const double d = shapes[s].distance(x, n);
          if (d < 0 && d >= -depth) {
            out.x.push_back(x);
            out.obstacle.push_back(s == container ? kWallObstacle : static_cast<std::uint32_t>(s));
            break;
          }
        }
      }
  return out;
}

} // namespace kf
