// Bounce samples against closed forms: the form factor of a differential area
// to a parallel coaxial disc, R²/(R²+H²) (part of the mesh, or an occluder's,
// listed apart); the inside of a closed sphere (every direction ends on the
// sphere: the weights sum to 1); and the rays that must carry nothing (the
// back of a face, an occluder when its hits are not asked for).
#include "visibility/bounce.h"

#include <gtest/gtest.h>

#include <cmath>

#include "geometry/primitives.h"

namespace relight {
namespace {

// A fan disc of radius r at height z, its front (normals) facing down (-Z) or up.
TriangleMesh Disc(float r, float z, bool facing_down, int segments = 256) {
  TriangleMesh m;
  m.vertices.push_back({0, 0, z});
  for (int k = 0; k < segments; ++k) {
    const double a = 2 * M_PI * k / segments;
    m.vertices.push_back({float(r * std::cos(a)), float(r * std::sin(a)), z});
  }
  for (int k = 0; k < segments; ++k) {
    const int a = 1 + k, b = 1 + (k + 1) % segments;
    m.faces.push_back(facing_down ? Eigen::Vector3i(0, b, a) : Eigen::Vector3i(0, a, b));
  }
  m.ComputeVertexNormals();
  return m;
}

// `a` with `b`'s vertices and faces appended.
TriangleMesh Append(TriangleMesh a, const TriangleMesh& b) {
  const int offset = int(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  a.normals.insert(a.normals.end(), b.normals.begin(), b.normals.end());
  for (const auto& f : b.faces) a.faces.push_back(f + Eigen::Vector3i::Constant(offset));
  return a;
}

double WeightSum(const BounceSamples& s, uint32_t v) {
  double sum = 0;
  for (uint32_t k = s.first[v]; k < s.first[v + 1]; ++k) sum += s.weight[k];
  return sum;
}

TEST(BounceTest, FormFactorToACoaxialDiscMatchesClosedForm) {
  const float radius = 0.8f, height = 0.6f;
  const TriangleMesh receiver = Disc(0.01f, 0.0f, /*facing_down=*/false, 8);  // vertex 0 faces +Z at the origin
  const TriangleMesh scene = Append(receiver, Disc(radius, height, /*facing_down=*/true));
  const RayCaster caster({&scene});
  BounceOptions o;
  o.rays_per_side = 64;
  const BounceSamples s = ComputeBounceSamples(scene, caster, o);
  ASSERT_EQ(s.num_vertices(), scene.num_vertices());
  const double expected = radius * radius / (radius * radius + height * height);  // 0.64
  EXPECT_NEAR(WeightSum(s, 0), expected, 0.01 * expected);
  // Every sample of the receiver's centre lies on the disc (vertices 9 and up), each weight positive.
  for (uint32_t k = s.first[0]; k < s.first[1]; ++k) {
    EXPECT_GE(s.hit_vertex[k], 9u);
    EXPECT_GT(s.weight[k], 0.0f);
  }
  // Gathering a uniform radiance B from the disc gives B times the form factor.
  std::vector<float> radiance(scene.num_vertices() * 3, 2.0f);
  EXPECT_NEAR(s.Gather(0, radiance.data(), 3, 1), 2.0 * expected, 0.02 * expected);
}

TEST(BounceTest, NoBounceFromOccludersOrTheBackOfAFace) {
  const TriangleMesh receiver = Disc(0.01f, 0.0f, false, 8);
  BounceOptions o;
  o.rays_per_side = 32;
  {
    // The same disc, its lit side facing away from the receiver: the rays hit its back.
    const TriangleMesh scene = Append(receiver, Disc(0.8f, 0.6f, /*facing_down=*/false));
    const RayCaster caster({&scene});
    const BounceSamples s = ComputeBounceSamples(scene, caster, o);
    EXPECT_EQ(WeightSum(s, 0), 0.0);
  }
  {
    // The disc as an occluder (another mesh of the caster): it blocks light but has no recovered radiance.
    const TriangleMesh disc = Disc(0.8f, 0.6f, true);
    const RayCaster caster({&receiver, &disc});
    const BounceSamples s = ComputeBounceSamples(receiver, caster, o);
    EXPECT_TRUE(s.empty());
    // Asked for, the occluder's hits are listed apart, indexing its own vertices: the same form factor.
    BounceSamples from_occluder;
    const BounceSamples again = ComputeBounceSamples(receiver, caster, o, &from_occluder);
    EXPECT_TRUE(again.empty());
    ASSERT_EQ(from_occluder.num_vertices(), receiver.num_vertices());
    EXPECT_NEAR(WeightSum(from_occluder, 0), 0.64, 0.02 * 0.64);
    for (uint32_t h : from_occluder.hit_vertex) EXPECT_LT(h, disc.num_vertices());
  }
}

TEST(BounceTest, InsideAClosedSphereEveryDirectionBounces) {
  TriangleMesh sphere = MakeOctasphere(3);
  for (auto& f : sphere.faces) std::swap(f[1], f[2]);  // inward-facing
  sphere.ComputeVertexNormals();
  const RayCaster caster({&sphere});
  BounceOptions o;
  o.rays_per_side = 16;
  const BounceSamples s = ComputeBounceSamples(sphere, caster, o);
  double worst = 0;
  for (uint32_t v = 0; v < sphere.num_vertices(); ++v) worst = std::max(worst, std::abs(WeightSum(s, v) - 1.0));
  // Only the share of rays landing on faces around the vertex itself (no self-bounce) is missing.
  EXPECT_LT(worst, 0.01);
}

}  // namespace
}  // namespace relight
