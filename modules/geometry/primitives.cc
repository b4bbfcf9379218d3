#include "geometry/primitives.h"

#include <cmath>
#include <map>
#include <vector>

namespace relight {

namespace {

// Splits every face of (`vertices` on the unit sphere, `faces`) into four `times` times, the new vertices the
// normalised edge midpoints (shared by the edge's two faces), in the vertices' precision.
template <typename Vector>
void SubdivideOnSphere(int times, std::vector<Vector>* vertices, std::vector<Eigen::Vector3i>* faces) {
  for (int l = 0; l < times; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      vertices->push_back(((*vertices)[a] + (*vertices)[b]).normalized());
      return mid[key] = static_cast<int>(vertices->size()) - 1;
    };
    std::vector<Eigen::Vector3i> next;
    next.reserve(faces->size() * 4);
    for (const auto& f : *faces) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      next.emplace_back(f[0], ab, ca);
      next.emplace_back(f[1], bc, ab);
      next.emplace_back(f[2], ca, bc);
      next.emplace_back(ab, bc, ca);
    }
    *faces = std::move(next);
  }
}

}  // namespace

TriangleMesh MakeIcosphere(int subdivisions) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<Eigen::Vector3i> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                    {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                    {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  SubdivideOnSphere(subdivisions, &v, &f);
  TriangleMesh m;
  for (const auto& p : v) {
    m.vertices.push_back(p.cast<float>());
    m.normals.push_back(p.cast<float>());
  }
  m.faces = std::move(f);
  return m;
}

TriangleMesh MakeOctasphere(int levels) {
  TriangleMesh m;
  m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  SubdivideOnSphere(levels, &m.vertices, &m.faces);
  m.ComputeVertexNormals();
  return m;
}

TriangleMesh MakeBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.emplace_back(q[0], q[1], q[2]);
    m.faces.emplace_back(q[0], q[2], q[3]);
  }
  m.ComputeVertexNormals();
  return m;
}

TriangleMesh MakeGrid(float x0, float x1, float y0, float y1, float z, int nx, int ny) {
  TriangleMesh m;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.vertices.emplace_back(x0 + (x1 - x0) * i / nx, y0 + (y1 - y0) * j / ny, z);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i;
      m.faces.emplace_back(a, a + 1, a + nx + 2);
      m.faces.emplace_back(a, a + nx + 2, a + nx + 1);
    }
  m.normals.assign(m.vertices.size(), Eigen::Vector3f::UnitZ());
  return m;
}

}  // namespace relight
