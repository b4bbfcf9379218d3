// Shapes against closed forms: closed, outward-oriented surfaces whose volumes
// (divergence theorem) match the analytic ones; convexity of the sphere and
// non-convexity of the blob; normalisation onto the ground; up-axis rotation;
// subdivision and simplification that keep the surface; mesh files brought
// into the scene frame.
#include "synth/shapes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "core/error.h"
#include "core/fs.h"
#include "geometry/mesh_io.h"
#include "meshing/mesh_cleanup.h"
#include "testing/testing.h"

namespace relight {
namespace {

// Signed volume by the divergence theorem (positive for outward faces of a closed mesh).
double Volume(const TriangleMesh& m) {
  double v = 0;
  for (const auto& f : m.faces)
    v += m.vertices[f[0]].cast<double>().dot(m.vertices[f[1]].cast<double>().cross(m.vertices[f[2]].cast<double>()));
  return v / 6;
}

// Every undirected edge is shared by exactly two faces, traversed once in each direction.
bool ClosedAndConsistent(const TriangleMesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    if (count != 1) return false;
    auto it = directed.find({edge.second, edge.first});
    if (it == directed.end() || it->second != 1) return false;
  }
  return true;
}

// Faces whose normal agrees with their vertices' normals (outward shading normals).
double AgreeingFraction(const TriangleMesh& m) {
  int agree = 0;
  for (size_t i = 0; i < m.faces.size(); ++i) {
    const auto& f = m.faces[i];
    const Eigen::Vector3f n = m.FaceNormal(int(i));
    agree += n.dot(m.normals[f[0]] + m.normals[f[1]] + m.normals[f[2]]) > 0;
  }
  return double(agree) / m.faces.size();
}

// Faces whose supporting plane has a vertex clearly in front of it (none for a convex mesh).
int NonConvexFaces(const TriangleMesh& m, double tol) {
  int count = 0;
  for (size_t i = 0; i < m.faces.size(); i += 7) {
    const Eigen::Vector3f n = m.FaceNormal(int(i));
    const Eigen::Vector3f p = m.vertices[m.faces[i][0]];
    for (const auto& v : m.vertices)
      if (n.dot(v - p) > tol) {
        ++count;
        break;
      }
  }
  return count;
}

TEST(ShapesTest, SphereIsClosedConvexAndRound) {
  const TriangleMesh s = MakeSphere(2000);
  EXPECT_GE(s.num_vertices(), 2000u);
  EXPECT_TRUE(ClosedAndConsistent(s));
  EXPECT_EQ(AgreeingFraction(s), 1.0);
  for (size_t i = 0; i < s.num_vertices(); ++i) {
    EXPECT_NEAR(s.vertices[i].norm(), 1.0f, 1e-6f);
    EXPECT_NEAR(s.normals[i].dot(s.vertices[i]), 1.0f, 1e-6f);
  }
  // Inscribed polyhedron: volume slightly below 4/3 pi, within the chord error.
  EXPECT_NEAR(Volume(s), 4.0 / 3.0 * M_PI, 0.01 * 4.0 / 3.0 * M_PI);
  EXPECT_LT(Volume(s), 4.0 / 3.0 * M_PI);
  EXPECT_EQ(NonConvexFaces(s, 1e-6), 0);
}

TEST(ShapesTest, TorusKnotIsAClosedTubeOfTheRightVolume) {
  const TriangleMesh k = MakeTorusKnot(20000);
  EXPECT_GE(k.num_vertices(), 20000u);
  EXPECT_TRUE(ClosedAndConsistent(k));
  EXPECT_EQ(AgreeingFraction(k), 1.0);
  // A tube of radius r along a curve of length L has volume pi r^2 L (Pappus, for a tube that does not
  // overlap itself). Curve (2 + cos 3t)(cos 2t, sin 2t) + sin 3t z.
  double length = 0;
  const int n = 100000;
  auto curve = [](double t) {
    const double r = 2.0 + std::cos(3 * t);
    return Eigen::Vector3d(r * std::cos(2 * t), r * std::sin(2 * t), std::sin(3 * t));
  };
  for (int i = 0; i < n; ++i) length += (curve(2 * M_PI * (i + 1) / n) - curve(2 * M_PI * i / n)).norm();
  const double expected = M_PI * 0.5 * 0.5 * length;
  EXPECT_NEAR(Volume(k), expected, 0.01 * expected);
  EXPECT_GT(NonConvexFaces(k, 1e-3), 0);
}

TEST(ShapesTest, BlobIsClosedAndNotConvex) {
  const TriangleMesh b = MakeBlob(3000, 7);
  EXPECT_TRUE(ClosedAndConsistent(b));
  EXPECT_GT(Volume(b), 0);
  EXPECT_GT(AgreeingFraction(b), 0.99);
  EXPECT_GT(NonConvexFaces(b, 1e-3), 20);
  // Deterministic in the seed, different across seeds.
  EXPECT_EQ(MakeBlob(3000, 7).vertices, b.vertices);
  EXPECT_NE(MakeBlob(3000, 8).vertices, b.vertices);
  EXPECT_THROW(MakeShape("teapot", 100, 1), UserError);
}

TEST(ShapesTest, BoxAndGroundHaveExactAreasAndVolumes) {
  const TriangleMesh box = MakeBox({-1, 0, 0}, {1, 0.5, 3}, 4);
  EXPECT_NEAR(Volume(box), 2 * 0.5 * 3, 1e-5);
  EXPECT_NEAR(box.SurfaceArea(), 2 * (2 * 0.5 + 2 * 3 + 0.5 * 3), 1e-4);
  EXPECT_EQ(AgreeingFraction(box), 1.0);
  const TriangleMesh ground = MakeGroundPlane(6, 10);
  EXPECT_NEAR(ground.SurfaceArea(), 36, 1e-4);
  EXPECT_EQ(ground.num_vertices(), 121u);
  for (size_t i = 0; i < ground.num_faces(); ++i) EXPECT_GT(ground.FaceNormal(int(i)).z(), 0.999f);
}

// The disk: a hexagonal tiling of 6 R² triangles over 1 + 3 R (R + 1) vertices whose area is that of the
// regular 6R-gon inscribed in the circle, every triangle facing +Z and none degenerate, and every edge
// shared by two triangles except the 6R on the rim (one disk, no holes, no overlaps).
TEST(ShapesTest, GroundDiskTilesTheCircle) {
  for (int rings : {1, 2, 7, 40}) {
    const double size = 6.0, r = size / 2;
    const TriangleMesh disk = MakeGroundDisk(size, rings);
    ASSERT_EQ(disk.num_vertices(), size_t(1 + 3 * rings * (rings + 1))) << rings;
    ASSERT_EQ(disk.num_faces(), size_t(6 * rings * rings)) << rings;
    const int n = 6 * rings;
    EXPECT_NEAR(disk.SurfaceArea(), 0.5 * n * r * r * std::sin(2 * M_PI / n), 1e-4 * r * r) << rings;
    const double edge = r / rings;
    std::map<std::pair<int, int>, int> edges;
    for (size_t f = 0; f < disk.num_faces(); ++f) {
      EXPECT_GT(disk.FaceNormal(int(f)).z(), 0.999f) << rings << " face " << f;
      EXPECT_GT(disk.FaceArea(int(f)), 0.2 * edge * edge) << rings << " face " << f;
      const Eigen::Vector3i& t = disk.faces[f];
      for (int e = 0; e < 3; ++e) {
        const int a = t[e], b = t[(e + 1) % 3];
        ++edges[{std::min(a, b), std::max(a, b)}];
      }
    }
    int rim = 0;
    for (const auto& [e, count] : edges) {
      ASSERT_LE(count, 2) << rings;
      if (count == 1) {
        ++rim;
        EXPECT_NEAR(disk.vertices[e.first].head<2>().norm(), r, 1e-5) << rings;
        EXPECT_NEAR(disk.vertices[e.second].head<2>().norm(), r, 1e-5) << rings;
      }
    }
    EXPECT_EQ(rim, n) << rings;
  }
}

TEST(ShapesTest, NormalizeRotateAndSubdivide) {
  TriangleMesh box = MakeBox({0, 0, 0}, {1, 4, 2}, 1);  // tallest along +y
  RotateUp(&box, "+y", 0);
  Eigen::AlignedBox3f bb = box.BoundingBox();
  EXPECT_NEAR(bb.sizes().z(), 4, 1e-5);  // +y now points up
  NormalizeOntoGround(&box, 2.0);
  bb = box.BoundingBox();
  EXPECT_NEAR(bb.sizes().maxCoeff(), 2.0, 1e-5);
  EXPECT_NEAR(bb.min().z(), 0.0, 1e-6);
  EXPECT_NEAR(bb.center().x(), 0.0, 1e-6);
  EXPECT_NEAR(bb.center().y(), 0.0, 1e-6);
  for (const auto& n : box.normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
  // "+x" up, then a quarter turn of yaw: x -> z, and the old z (extent 2) ends up along y after the yaw.
  TriangleMesh along_x = MakeBox({0, 0, 0}, {3, 1, 2}, 1);
  RotateUp(&along_x, "+x", 90);
  const Eigen::Vector3f sizes = along_x.BoundingBox().sizes();
  EXPECT_NEAR(sizes.z(), 3, 1e-5);
  EXPECT_NEAR(sizes.x(), 1, 1e-5);
  EXPECT_NEAR(sizes.y(), 2, 1e-5);
  for (size_t i = 0; i < along_x.num_faces(); ++i)  // normals rotate with the vertices
    EXPECT_GT(along_x.FaceNormal(int(i)).dot(along_x.normals[along_x.faces[i][0]]), 0.999f);
  EXPECT_THROW(RotateUp(&along_x, "up", 0), UserError);
  const double area = box.SurfaceArea();
  box.Property("w0") = std::vector<float>(box.num_vertices(), 0.25f);
  SubdivideToVertices(&box, 1000);
  EXPECT_GE(box.num_vertices(), 1000u);
  EXPECT_NEAR(box.SurfaceArea(), area, 1e-4 * area);
  for (float w : *box.FindProperty("w0")) EXPECT_EQ(w, 0.25f);
}

// Mesh files denser than needed are remeshed down: about the requested count,
// still a closed 2-manifold, still on the original surface.
TEST(ShapesTest, SimplifyToVerticesKeepsTheSurface) {
  TriangleMesh sphere = MakeSphere(10000);  // unit radius, about 10K vertices
  const size_t before = sphere.num_vertices();
  ASSERT_GT(before, 8000u);
  EXPECT_FALSE(SimplifyToVertices(&sphere, int(before), "sphere"));  // already small enough: untouched
  EXPECT_EQ(sphere.num_vertices(), before);
  ASSERT_TRUE(SimplifyToVertices(&sphere, 2000, "sphere"));
  EXPECT_NEAR(double(sphere.num_vertices()), 2000.0, 300.0);
  EXPECT_EQ(FindManifoldViolation(sphere), "");
  EXPECT_EQ(CountBoundaryEdges(sphere), 0u);
  double worst = 0;
  for (const auto& v : sphere.vertices) worst = std::max(worst, std::abs(double(v.norm()) - 1.0));
  EXPECT_LT(worst, 0.01);  // vertices stay on the sphere (chords of ~0.08 sag by < 0.001)
  EXPECT_EQ(sphere.normals.size(), sphere.num_vertices());
}

TEST(ShapesTest, BoundingSphereContainsEveryVertex) {
  const TriangleMesh k = MakeTorusKnot(2000);
  Eigen::Vector3d c;
  double r;
  BoundingSphere(k, &c, &r);
  double farthest = 0;
  for (const auto& v : k.vertices) {
    EXPECT_LE((v.cast<double>() - c).norm(), r + 1e-9);
    farthest = std::max(farthest, (v.cast<double>() - c).norm());
  }
  EXPECT_NEAR(farthest, r, 1e-9);  // tight
  EXPECT_TRUE(c.isApprox(k.BoundingBox().center().cast<double>()));
}

}  // namespace
}  // namespace relight
