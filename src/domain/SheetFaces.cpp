#include "domain/SheetFaces.hpp"

namespace kf {

SheetFaces build_sheet_faces(const KnitMesh& mesh) {
  SheetFaces s;
  auto quad = [&s](std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
    s.faces.push_back({a, b, c});
    s.faces.push_back({a, c, d});
  };
  for (const KnitPieceLayout& L : mesh.pieces) {
    for (int layer : {0, 2}) {
      if (!L.grid) {
        for (const auto& q : L.quads)
          quad(L.index(layer, int(q[0]), 0), L.index(layer, int(q[1]), 0),
               L.index(layer, int(q[2]), 0), L.index(layer, int(q[3]), 0));
        continue;
      }
      const int columns = L.periodic_u ? L.nu : L.nu - 1;
      for (int j = 0; j + 1 < L.nv; ++j)
        for (int i = 0; i < columns; ++i) {
          const int i1 = (i + 1) % L.nu;
          quad(L.index(layer, i, j), L.index(layer, i1, j), L.index(layer, i1, j + 1),
               L.index(layer, i, j + 1));
        }
    }
  }
  // Per point, its faces (counting sort by point).
  s.offsets.assign(mesh.x.size() + 1, 0);
  for (const auto& f : s.faces)
    for (std::uint32_t p : f)
      ++s.offsets[p + 1];
  for (std::size_t p = 0; p < mesh.x.size(); ++p)
    s.offsets[p + 1] += s.offsets[p];
  s.ids.resize(s.offsets.back());
  std::vector<std::uint32_t> fill(s.offsets.begin(), s.offsets.end() - 1);
  for (std::uint32_t f = 0; f < s.faces.size(); ++f)
    for (std::uint32_t p : s.faces[f])
      s.ids[fill[p]++] = f;
  return s;
}

} // namespace kf
