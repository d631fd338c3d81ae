#include "domain/KnitBuilder.hpp"

#include "domain/KnitMeshPiece.hpp"
#include "kernels/particles/KnitSet.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace kf {

namespace {

constexpr double kPi = 3.14159265358979323846;
using knit_build::kVolumeCellShare;

struct Frame3 {
  Vec3d n, u, w; // normal (or axis), u, w = n x u
};

Frame3 frame_of(const KnitPiece& p) {
  Frame3 f;
  f.n = p.normal * (1.0 / norm(p.normal));
  Vec3d u = p.u_axis - f.n * dot(p.u_axis, f.n);
  f.u = u * (1.0 / norm(u));
  f.w = cross(f.n, f.u);
  return f;
}

/// Rest position of node (i, j) of a piece in the given layer.
Vec3d node_position(const KnitPiece& p, const Frame3& f, double thickness, int layer, int i, int j,
                    int nu) {
  const double offset = 0.5 * thickness * (1 - layer); // layer 0 front (+t/2), 2 back (-t/2)
  if (p.shape == KnitShape::Patch) {
    const double a = p.width / p.wales, b = p.height / p.courses;
    return p.center + f.u * (i * a - 0.5 * p.width) + f.w * (j * b - 0.5 * p.height) + f.n * offset;
  }
  // Tube: around the axis n, starting at the seam u; the front layer is outside.
  const double theta = 2 * kPi * i / nu, radius = p.circumference / (2 * kPi);
  const Vec3d radial = f.u * std::cos(theta) + f.w * std::sin(theta);
  const double b = p.length / p.courses;
  return p.center + f.n * (j * b - 0.5 * p.length) + radial * (radius + offset);
}

} // namespace

namespace knit_build {

void add_spring(KnitMesh& mesh, std::uint32_t i, std::uint32_t j, double k, SpringKind kind,
                double damping_ratio) {
  const double mi = mesh.m[i], mj = mesh.m[j];
  Spring s;
  s.i = i;
  s.j = j;
  s.rest = norm(mesh.x[j] - mesh.x[i]);
  s.k = k;
  s.c = damping_ratio * 2.0 * std::sqrt(k * mi * mj / (mi + mj));
  s.kind = kind;
  KnitMeshStats& st = mesh.stats;
  if (kind == SpringKind::Stretch)
    st.longest_stretch = std::max(st.longest_stretch, s.rest);
  st.stiffest = std::max(st.stiffest, s.k);
  st.longest = std::max(st.longest, s.rest);
  ++st.springs;
  ++st.by_kind[static_cast<std::size_t>(kind)];
  if (mesh.spring_ends.size() < mesh.x.size())
    mesh.spring_ends.resize(mesh.x.size(), 0);
  st.widest = std::max({st.widest, ++mesh.spring_ends[i], ++mesh.spring_ends[j]});
  const std::vector<std::uint8_t>* keep = mesh.springs_of;
  if (!keep || (!keep->empty() && ((*keep)[i] || (*keep)[j])))
    mesh.springs.push_back(s);
}

void add_volume_cell(KnitMesh& mesh, const std::array<std::uint32_t, 4>& point, double kh) {
  KnitMeshStats& st = mesh.stats;
  if (mesh.cell_ends.size() < mesh.x.size())
    mesh.cell_ends.resize(mesh.x.size(), 0);
  bool kept = !mesh.cells_of;
  for (const std::uint32_t p : point) {
    st.widest_cells = std::max(st.widest_cells, ++mesh.cell_ends[p]);
    kept = kept || (!mesh.cells_of->empty() && (*mesh.cells_of)[p]);
  }
  const auto index = static_cast<std::uint32_t>(st.cells++);
  if (!kept)
    return;
  VolumeCell c;
  c.point = point;
  const Vec3d &xp = mesh.x[point[0]], &xo = mesh.x[point[1]], &xa = mesh.x[point[2]],
              &xb = mesh.x[point[3]];
  c.rest_volume = tet_volume(xp, xo, xa, xb);
  c.k = kh / norm2(tet_volume_gradient(xp, xo, xa, xb, 0));
  mesh.volumes.push_back(c);
  mesh.volume_index.push_back(index);
}

} // namespace knit_build

KnitMesh build_knit(const Scene& scene, const std::vector<std::uint8_t>* springs_of,
                    const std::vector<std::uint8_t>* cells_of) {
  const auto& mat = scene.knit;
  const double t = mat.thickness, half_t = 0.5 * t;
  KnitMesh mesh;
  mesh.springs_of = springs_of;
  mesh.cells_of = cells_of;
  for (std::size_t pi = 0; pi < scene.knit.pieces.size(); ++pi) {
    const KnitPiece& p = scene.knit.pieces[pi];
    if (p.shape == KnitShape::Mesh) {
      mesh.pieces.push_back(append_mesh_piece(p, mat, static_cast<std::uint16_t>(pi), mesh));
      continue;
    }
    const Frame3 f = frame_of(p);
    KnitPieceLayout L;
    L.first = static_cast<std::uint32_t>(mesh.x.size());
    L.periodic_u = p.shape == KnitShape::Tube;
    L.nu = L.periodic_u ? p.wales : p.wales + 1;
    L.nv = p.courses + 1;
    const double a = L.periodic_u ? p.circumference / p.wales : p.width / p.wales;
    const double b = (L.periodic_u ? p.length : p.height) / p.courses;
    // Share of the node spacing a point stands for across u and v (half on open edges).
    auto share_u = [&](int i) { return (!L.periodic_u && (i == 0 || i == L.nu - 1)) ? 0.5 : 1.0; };
    auto share_v = [&](int j) { return (j == 0 || j == L.nv - 1) ? 0.5 : 1.0; };
    auto area = [&](int i, int j) { return a * b * share_u(i) * share_v(j); };

    for (int layer = 0; layer < 3; ++layer)
      for (int j = 0; j < L.nv; ++j)
        for (int i = 0; i < L.nu; ++i) {
          mesh.x.push_back(node_position(p, f, t, layer, i, j, L.nu));
          mesh.v.push_back(p.velocity);
          mesh.m.push_back(mat.mass_per_area * area(i, j) / 3.0);
          mesh.layer.push_back(static_cast<std::uint8_t>(layer));
          mesh.piece.push_back(static_cast<std::uint16_t>(pi));
        }

    auto spring = [&](std::uint32_t i, std::uint32_t j, double k, SpringKind kind) {
      knit_build::add_spring(mesh, i, j, k, kind, mat.damping_ratio);
    };
    // Neighbour along u, wrapping on a tube; -1 past an open edge.
    auto iu = [&](int i, int di) {
      const int k = i + di;
      if (L.periodic_u)
        return ((k % L.nu) + L.nu) % L.nu;
      return (k < 0 || k >= L.nu) ? -1 : k;
    };
    // The moduli are the whole fabric's; each of the three layers carries a third.
    for (int layer = 0; layer < 3; ++layer)
      for (int j = 0; j < L.nv; ++j)
        for (int i = 0; i < L.nu; ++i) {
          const std::uint32_t p0 = L.index(layer, i, j);
          if (int i1 = iu(i, 1); i1 >= 0 && !(L.periodic_u && L.nu < 3 && i1 < i)) // stretch u
            spring(p0, L.index(layer, i1, j), mat.stretch * b * share_v(j) / a / 3,
                   SpringKind::Stretch);
          if (j + 1 < L.nv) // stretch v
            spring(p0, L.index(layer, i, j + 1), mat.stretch * a * share_u(i) / b / 3,
                   SpringKind::Stretch);
          if (int i1 = iu(i, 1); i1 >= 0 && j + 1 < L.nv && mat.shear > 0) { // two diagonals
            const double kd = mat.shear * (a * a + b * b) / (2 * a * b) / 3;
            spring(p0, L.index(layer, i1, j + 1), kd, SpringKind::Shear);
            spring(L.index(layer, i1, j), L.index(layer, i, j + 1), kd, SpringKind::Shear);
          }
          if (mat.bend > 0) {
            if (int i2 = iu(i, 2); i2 >= 0 && !(L.periodic_u && L.nu <= 4 && i2 < i))
              spring(p0, L.index(layer, i2, j), mat.bend * b * share_v(j) / (2 * a) / 3,
                     SpringKind::Bend);
            if (j + 2 < L.nv)
              spring(p0, L.index(layer, i, j + 2), mat.bend * a * share_u(i) / (2 * b) / 3,
                     SpringKind::Bend);
          }
        }
    // Between adjacent layers: straight springs keep the thickness (compression modulus over the
    // node's area), diagonal ones to the twin's edge neighbours resist layers sliding (from the
    // through-thickness shear modulus: k = G A l^2 / (2 s^2 (t/2)), s the in-plane spacing).
    for (int layer = 0; layer < 2; ++layer)
      for (int j = 0; j < L.nv; ++j)
        for (int i = 0; i < L.nu; ++i) {
          const double A = area(i, j);
          const std::uint32_t p0 = L.index(layer, i, j);
          spring(p0, L.index(layer + 1, i, j),
                 (1 - kVolumeCellShare) * mat.compression * A / half_t, SpringKind::VolumeStraight);
          if (mat.layer_shear <= 0)
            continue;
          const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
          for (int d = 0; d < 4; ++d) {
            const int i1 = iu(i, di[d]), j1 = j + dj[d];
            if (i1 < 0 || j1 < 0 || j1 >= L.nv)
              continue;
            const double s = d < 2 ? a : b, l2 = s * s + half_t * half_t;
            spring(p0, L.index(layer + 1, i1, j1), mat.layer_shear * A * l2 / (2 * s * s * half_t),
                   SpringKind::VolumeDiagonal);
          }
        }
    // Volume cells: each front and back point over the corner triangles of its middle-layer twin
    // (one per quadrant that exists). Together they carry kVolumeCellShare of the compression
    // stiffness: a thickness change dh changes V by |(a - o) x (b - o)| / 6 dh, so
    // k_V = k_h / |dV/dp|^2 gives the quadrant its share k_h of compression * A / (t/2).
    for (int layer = 0; layer < 3; layer += 2)
      for (int j = 0; j < L.nv; ++j)
        for (int i = 0; i < L.nu; ++i) {
          std::vector<std::array<int, 2>> quads;
          for (int di = -1; di <= 1; di += 2)
            for (int dj = -1; dj <= 1; dj += 2)
              if (iu(i, di) >= 0 && j + dj >= 0 && j + dj < L.nv)
                quads.push_back({di, dj});
          const double kh = kVolumeCellShare * mat.compression * area(i, j) / half_t / quads.size();
          for (const auto& q : quads)
            knit_build::add_volume_cell(mesh,
                                        {L.index(layer, i, j), L.index(1, i, j),
                                         L.index(1, iu(i, q[0]), j), L.index(1, i, j + q[1])},
                                        kh);
        }
    mesh.pieces.push_back(L);
  }
  // Pins: a point whose rest position lies in a pin's box follows that pin (first pin wins).
  mesh.handle.assign(mesh.x.size(), kFreePoint);
  for (std::size_t p = 0; p < scene.knit.pins.size(); ++p) {
    const auto& pin = scene.knit.pins[p];
    for (std::size_t i = 0; i < mesh.x.size(); ++i) {
      const Vec3d& x = mesh.x[i];
      if (mesh.handle[i] == kFreePoint && x.x >= pin.min.x && x.x <= pin.max.x &&
          x.y >= pin.min.y && x.y <= pin.max.y && x.z >= pin.min.z && x.z <= pin.max.z)
        mesh.handle[i] = static_cast<std::uint32_t>(p);
    }
  }
  mesh.springs_of = mesh.cells_of = nullptr; // (the caller's flags: not kept past the build)
  std::vector<std::uint32_t>().swap(mesh.spring_ends);
  std::vector<std::uint32_t>().swap(mesh.cell_ends);
  return mesh;
}

} // namespace kf
