#include "geometry/primitives.h"

#include <map>

namespace relight {

TriangleMesh MakeIcosphere(int levels) {
  TriangleMesh m;
  m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      m.vertices.push_back((m.vertices[a] + m.vertices[b]).normalized());
      return mid[key] = static_cast<int>(m.vertices.size()) - 1;
    };
    std::vector<Eigen::Vector3i> faces;
    faces.reserve(m.faces.size() * 4);
    for (const auto& f : m.faces) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      faces.emplace_back(f[0], ab, ca);
      faces.emplace_back(f[1], bc, ab);
      faces.emplace_back(f[2], ca, bc);
      faces.emplace_back(ab, bc, ca);
    }
    m.faces = std::move(faces);
  }
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
