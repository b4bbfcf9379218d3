#include "visibility/visibility.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "geometry/mesh_io.h"
#include "geometry/primitives.h"
#include "sphere/octahedral.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TriangleMesh Quad(float x0, float x1, float y0, float y1, float z) {
  TriangleMesh m;
  m.vertices = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  m.ComputeVertexNormals();
  return m;
}

// Solid angle of the rectangle [x0,x1]×[y0,y1] at height h above the origin.
double RectangleSolidAngle(double x0, double x1, double y0, double y1, double h) {
  auto f = [h](double x, double y) { return std::atan(x * y / (h * std::sqrt(x * x + y * y + h * h))); };
  return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0);
}

double BlockedSolidAngle(const std::vector<float>& map, int n) {
  double blocked = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) blocked += (1.0 - map[j * n + i]) * HemiOctTexelSolidAngle(i, j, n);
  return blocked;
}

TEST(VisibilityTest, OccluderAboveAPlaneMatchesAnalyticSolidAngle) {
  TriangleMesh ground = Quad(-50, 50, -50, 50, 0);
  // Add the query vertex at the origin (a fan around it keeps it a mesh vertex).
  ground.vertices.push_back({0, 0, 0});
  ground.normals.push_back({0, 0, 1});
  const TriangleMesh blocker = Quad(-0.3f, 0.7f, 0.2f, 0.9f, 0.5f);
  const RayCaster caster({&ground, &blocker});
  VisibilityOptions o;
  o.resolution = 32;
  o.supersampling = 4;
  std::vector<float> maps;
  BakeVisibilityMaps(ground, caster, {4}, o, &maps);
  const double expected = RectangleSolidAngle(-0.3, 0.7, 0.2, 0.9, 0.5);
  const double measured = BlockedSolidAngle(maps, 32);
  EXPECT_NEAR(measured, expected, 0.01 * expected) << "analytic " << expected;
  // Rays below the horizon never exist: an empty scene is fully open.
  const TriangleMesh far_away = Quad(100, 101, 100, 101, -5);
  const RayCaster open({&ground, &far_away});
  BakeVisibilityMaps(ground, open, {4}, o, &maps);
  EXPECT_NEAR(BlockedSolidAngle(maps, 32), 0.0, 1e-9);
}

TEST(VisibilityTest, VertexInsideClosedBoxIsFullyOccluded) {
  TriangleMesh floor = Quad(-1, 1, -1, 1, 0);
  const TriangleMesh box = MakeBox({-2, -2, -1}, {2, 2, 3});
  const RayCaster caster({&floor, &box});
  VisibilityOptions o;
  std::vector<float> maps;
  BakeVisibilityMaps(floor, caster, {0, 2}, o, &maps);
  for (float v : maps) EXPECT_EQ(v, 0.0f);
}

TEST(VisibilityTest, CoarseConvexMeshHasNoSelfShadowAcne) {
  const TriangleMesh sphere = MakeOctasphere(1);  // 18 vertices, very coarse
  const RayCaster caster({&sphere});
  VisibilityOptions o;
  o.resolution = 16;
  o.supersampling = 3;
  std::vector<uint32_t> all(sphere.num_vertices());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<uint32_t>(i);
  std::vector<float> maps;
  BakeVisibilityMaps(sphere, caster, all, o, &maps);
  for (float v : maps) EXPECT_EQ(v, 1.0f);
}

TEST(VisibilityTest, StageWritesSparseHaarAndResumes) {
  InitLogging("visibility_test", "", LogLevel::kError);
  setenv("RELIGHT_PROGRESS", "off", 1);
  testing::TempDir dir;
  fs::create_directories(dir / "mesh");
  TriangleMesh mesh = MakeOctasphere(3);
  for (auto& v : mesh.vertices) v.z() += 1.05f;  // just above the ground
  mesh.ComputeVertexNormals();
  WriteMeshPly(dir / "mesh/mesh.ply", mesh);
  WriteMeshPly(dir / "mesh/occluders.ply", Quad(-5, 5, -5, 5, 0));
  VisibilityOptions o;
  o.resolution = 16;
  o.chunk_vertices = 100;
  o.keep_energy = 1.0;
  const VisibilitySummary s = RunVisibility(o, {dir / "mesh"}, dir / "out");
  EXPECT_EQ(s.vertices, mesh.num_vertices());
  const VisibilityData data = ReadVisibility(dir / "out/visibility.bin");
  ASSERT_EQ(data.per_vertex.size(), mesh.num_vertices());
  EXPECT_EQ(data.resolution, 16);
  // With every coefficient kept, the stored maps equal a direct bake.
  std::vector<float> direct;
  const TriangleMesh occluders = ReadMesh(dir / "mesh/occluders.ply");
  const RayCaster caster2({&mesh, &occluders});
  BakeVisibilityMaps(mesh, caster2, {0, 5, 200}, o, &direct);
  for (int q = 0; q < 3; ++q) {
    const std::vector<float> stored = data.DenseMap(std::vector<size_t>{0, 5, 200}[q]);
    for (int t = 0; t < 256; ++t) EXPECT_NEAR(stored[t], direct[q * 256 + t], 1e-5);
  }
  // The bottom of the sphere sees the ground: its visibility is partly blocked.
  size_t lowest = 0;
  for (size_t v = 0; v < mesh.num_vertices(); ++v)
    if (mesh.vertices[v].z() < mesh.vertices[lowest].z()) lowest = v;
  const std::vector<float> low = data.DenseMap(lowest);
  EXPECT_LT(*std::min_element(low.begin(), low.end()), 0.5f);

  // Truncation keeps the stated share of the energy.
  o.keep_energy = 0.99;
  RunVisibility(o, {dir / "mesh"}, dir / "out2");
  const VisibilityData trunc = ReadVisibility(dir / "out2/visibility.bin");
  double err = 0, total = 0;
  for (size_t v = 0; v < mesh.num_vertices(); v += 7) {
    const auto a = data.DenseMap(v), b = trunc.DenseMap(v);
    for (int t = 0; t < 256; ++t) {
      err += (a[t] - b[t]) * (a[t] - b[t]);
      total += a[t] * a[t];
    }
  }
  EXPECT_LE(std::sqrt(err / total), std::sqrt(1 - 0.99) + 1e-6);

  // A damaged file is a clear error.
  const std::string bytes = ReadFileToString(dir / "out/visibility.bin");
  WriteFileAtomic(dir / "cut.bin", bytes.substr(0, bytes.size() - 3));
  EXPECT_THROW(ReadVisibility(dir / "cut.bin"), UserError);
}

}  // namespace
}  // namespace relight
