// Plain topological checks of triangle meshes (no CGAL), declared in
// mesh_cleanup.h: the stage verifies its own output with them and tests
// assert with them.
#include <algorithm>
#include <numeric>
#include <vector>

#include "meshing/mesh_cleanup.h"

namespace relight {
namespace {

int64_t EdgeKey(int a, int b) { return (int64_t(std::min(a, b)) << 32) | uint32_t(std::max(a, b)); }

int Find(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// Sorted edge list: (undirected key, directed flag) per face side; sorting
// keeps the checks O(F log F) on million-face meshes.
struct EdgeRecord {
  int64_t key;  // undirected
  int a, b;     // directed
  bool operator<(const EdgeRecord& o) const { return key < o.key || (key == o.key && a < o.a); }
};

std::vector<EdgeRecord> SortedEdges(const TriangleMesh& mesh) {
  std::vector<EdgeRecord> edges;
  edges.reserve(mesh.faces.size() * 3);
  for (const auto& t : mesh.faces) {
    for (int k = 0; k < 3; ++k) edges.push_back({EdgeKey(t[k], t[(k + 1) % 3]), t[k], t[(k + 1) % 3]});
  }
  std::sort(edges.begin(), edges.end());
  return edges;
}

}  // namespace

std::string FindManifoldViolation(const TriangleMesh& mesh) {
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return "face " + std::to_string(f) + " repeats a vertex";
  }
  // Each undirected edge: at most two faces, and then in opposite directions (consistent orientation).
  const std::vector<EdgeRecord> edges = SortedEdges(mesh);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    const std::string name = std::to_string(edges[i].a) + "-" + std::to_string(edges[i].b);
    if (j - i > 2) return "edge " + name + " has more than two faces";
    if (j - i == 2 && edges[i].a == edges[i + 1].a) {
      return "edge " + name + " is used twice in the same direction (inconsistent orientation)";
    }
    i = j;
  }
  // Vertex fans: the faces around a vertex, linked through shared edges, form one group.
  std::vector<int> offsets(mesh.vertices.size() + 1, 0);
  for (const auto& t : mesh.faces) {
    for (int k = 0; k < 3; ++k) ++offsets[t[k] + 1];
  }
  for (size_t v = 0; v < mesh.vertices.size(); ++v) offsets[v + 1] += offsets[v];
  std::vector<int> incident(offsets.back());
  std::vector<int> fill(offsets.begin(), offsets.end() - 1);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) incident[fill[mesh.faces[f][k]]++] = static_cast<int>(f);
  }
  std::vector<int> parent;
  std::vector<std::pair<int, int>> neighbours;  // (other vertex, local face index)
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const int begin = offsets[v], count = offsets[v + 1] - offsets[v];
    if (count <= 1) continue;
    parent.resize(count);
    std::iota(parent.begin(), parent.end(), 0);
    neighbours.clear();
    for (int i = 0; i < count; ++i) {
      const auto& t = mesh.faces[incident[begin + i]];
      for (int k = 0; k < 3; ++k) {
        if (t[k] != static_cast<int>(v)) neighbours.emplace_back(t[k], i);
      }
    }
    std::sort(neighbours.begin(), neighbours.end());
    for (size_t i = 1; i < neighbours.size(); ++i) {
      if (neighbours[i].first == neighbours[i - 1].first) {
        parent[Find(parent, neighbours[i].second)] = Find(parent, neighbours[i - 1].second);
      }
    }
    const int root = Find(parent, 0);
    for (int i = 1; i < count; ++i) {
      if (Find(parent, i) != root) {
        return "vertex " + std::to_string(v) + " joins separate fans of faces (non-manifold vertex)";
      }
    }
  }
  return "";
}

size_t CountBoundaryEdges(const TriangleMesh& mesh) {
  const std::vector<EdgeRecord> edges = SortedEdges(mesh);
  size_t boundary = 0;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    boundary += j - i == 1;
    i = j;
  }
  return boundary;
}

int CountComponents(const TriangleMesh& mesh) {
  std::vector<int> parent(mesh.faces.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::pair<int64_t, int>> edge_faces;
  edge_faces.reserve(mesh.faces.size() * 3);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) edge_faces.emplace_back(EdgeKey(mesh.faces[f][k], mesh.faces[f][(k + 1) % 3]), int(f));
  }
  std::sort(edge_faces.begin(), edge_faces.end());
  for (size_t i = 1; i < edge_faces.size(); ++i) {
    if (edge_faces[i].first == edge_faces[i - 1].first) {
      parent[Find(parent, edge_faces[i].second)] = Find(parent, edge_faces[i - 1].second);
    }
  }
  int count = 0;
  for (size_t f = 0; f < parent.size(); ++f) count += Find(parent, int(f)) == int(f);
  return count;
}

}  // namespace relight
