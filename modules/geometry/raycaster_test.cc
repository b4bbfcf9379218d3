#include "geometry/raycaster.h"

#include <gtest/gtest.h>

#include <random>

namespace relight {
namespace {

// Axis-aligned unit cube [0,1]^3 with outward-facing triangles.
TriangleMesh Cube() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.emplace_back(q[0], q[1], q[2]);
    m.faces.emplace_back(q[0], q[2], q[3]);
  }
  m.ComputeVertexNormals();
  return m;
}

TEST(RayCasterTest, HitsCubeAtExpectedDistance) {
  const TriangleMesh cube = Cube();
  RayCaster caster({&cube});
  const RayHit hit = caster.Intersect({{0.5f, 0.5f, 5.0f}, {0, 0, -1}});
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.t, 4.0f, 1e-5f);
  EXPECT_TRUE(hit.normal.isApprox(Eigen::Vector3f(0, 0, 1), 1e-5f));  // outward top face
  EXPECT_NEAR(hit.point.z(), 1.0f, 1e-5f);
  EXPECT_FALSE(caster.Intersect({{0.5f, 0.5f, 5.0f}, {0, 0, 1}}).hit);
  EXPECT_TRUE(caster.Occluded({{0.5f, 0.5f, 5.0f}, {0, 0, -1}}));
  EXPECT_FALSE(caster.Occluded({{0.5f, 0.5f, 5.0f}, {0, 0, -1}, 0.0f, 3.9f}));  // stops short
  EXPECT_NEAR(caster.SceneDiagonal(), std::sqrt(3.0f), 1e-6f);
}

TEST(RayCasterTest, StreamsAgreeWithSingleRays) {
  const TriangleMesh cube = Cube();
  TriangleMesh plane;
  plane.vertices = {{-5, -5, -1}, {5, -5, -1}, {5, 5, -1}, {-5, 5, -1}};
  plane.faces = {{0, 1, 2}, {0, 2, 3}};
  RayCaster caster({&cube, &plane});
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<Ray> rays;  // several of IntersectStream's chunks (4,096 rays), traced on all threads
  for (int i = 0; i < 10000; ++i) {
    rays.push_back({Eigen::Vector3f(u(rng), u(rng), 3.0f), Eigen::Vector3f(u(rng) * 0.5f, u(rng) * 0.5f, -1.0f)});
  }
  std::vector<RayHit> hits;
  caster.IntersectStream(rays, false, &hits);
  std::vector<uint8_t> occluded(rays.size());
  caster.OccludedStream(rays.data(), rays.size(), false, occluded.data());
  int cube_hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const RayHit single = caster.Intersect(rays[i]);
    ASSERT_EQ(single.hit, hits[i].hit);
    EXPECT_EQ(single.hit, occluded[i] != 0);
    if (single.hit) {
      EXPECT_EQ(single.geom_id, hits[i].geom_id);
      EXPECT_NEAR(single.t, hits[i].t, 1e-5f);
      cube_hits += single.geom_id == 0;
    }
  }
  EXPECT_GT(cube_hits, 500);
}

TEST(RayCasterTest, ShadingNormalAndPropertyInterpolation) {
  const TriangleMesh cube = Cube();
  RayCaster caster({&cube});
  const RayHit hit = caster.Intersect({{0.999f, 0.999f, 5.0f}, {0, 0, -1}});
  ASSERT_TRUE(hit.hit);
  // Near the corner (1,1,1) the interpolated vertex normal tilts towards the corner's diagonal.
  const Eigen::Vector3f n = caster.ShadingNormal(hit);
  EXPECT_GT(n.dot(Eigen::Vector3f(1, 1, 1).normalized()), 0.95f);
  std::vector<float> height(cube.vertices.size());
  for (size_t i = 0; i < height.size(); ++i) height[i] = cube.vertices[i].x();
  EXPECT_NEAR(caster.InterpolateProperty(hit, height), 0.999f, 1e-4f);
}

}  // namespace
}  // namespace relight
