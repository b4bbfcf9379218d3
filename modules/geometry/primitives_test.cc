#include "geometry/primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <utility>

namespace relight {
namespace {

// Signed volume enclosed by a closed mesh (positive when its faces wind counter-clockwise seen from outside).
double SignedVolume(const TriangleMesh& m) {
  double v = 0;
  for (const auto& f : m.faces) {
    v += m.vertices[f[0]].cast<double>().dot(m.vertices[f[1]].cast<double>().cross(m.vertices[f[2]].cast<double>()));
  }
  return v / 6;
}

// Every edge of a closed 2-manifold is shared by exactly two faces, once in each direction.
bool ClosedManifold(const TriangleMesh& m) {
  std::set<std::pair<int, int>> directed;
  for (const auto& f : m.faces) {
    for (int k = 0; k < 3; ++k) {
      if (!directed.insert({f[k], f[(k + 1) % 3]}).second) return false;
    }
  }
  for (const auto& [a, b] : directed) {
    if (!directed.count({b, a})) return false;
  }
  return true;
}

TEST(Primitives, IcosphereAndOctasphereAreClosedUnitSpheresOfTheStatedSize) {
  const double sphere_volume = 4.0 / 3.0 * M_PI;
  for (int s = 0; s <= 4; ++s) {
    const TriangleMesh ico = MakeIcosphere(s), octa = MakeOctasphere(s);
    const size_t pow4 = size_t(1) << (2 * s);
    EXPECT_EQ(ico.num_vertices(), 10 * pow4 + 2);
    EXPECT_EQ(ico.faces.size(), 20 * pow4);
    EXPECT_EQ(octa.num_vertices(), 4 * pow4 + 2);
    EXPECT_EQ(octa.faces.size(), 8 * pow4);
    for (const TriangleMesh* m : {&ico, &octa}) {
      ASSERT_EQ(m->normals.size(), m->num_vertices());
      for (size_t v = 0; v < m->num_vertices(); ++v) {
        EXPECT_NEAR(m->vertices[v].norm(), 1.0, 1e-6);
        EXPECT_GT(m->normals[v].dot(m->vertices[v]), 0.99);  // outward, about radial
      }
      EXPECT_TRUE(ClosedManifold(*m));
      // Inscribed polyhedron: below the sphere's volume, approaching it as the faces shrink: the relative deficit
      // times the face count tends to about 11 (icosphere) and 12 (octasphere) for evenly split faces.
      const double volume = SignedVolume(*m);
      EXPECT_GT(volume, 0);
      EXPECT_LT(volume, sphere_volume);
      EXPECT_LT(sphere_volume - volume, 13.0 / m->faces.size() * sphere_volume) << m->faces.size() << " faces";
    }
  }
}

TEST(Primitives, IcosphereNormalsAreExactlyRadial) {
  const TriangleMesh m = MakeIcosphere(3);
  for (size_t v = 0; v < m.num_vertices(); ++v) EXPECT_LT((m.normals[v] - m.vertices[v]).norm(), 1e-7);
}

}  // namespace
}  // namespace relight
