// Material sets and weight patterns: weights are a partition of unity, every
// material gets a real share of the surface, the pattern has spatial structure
// at the requested scale, and the written albedo is the blend of the materials'
// Lambertian coefficients.
#include "synth/materials.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "synth/shapes.h"

namespace relight {
namespace {

std::vector<double> WeightsOf(const TriangleMesh& mesh, int num_materials, size_t v) {
  std::vector<double> w(num_materials);
  for (int m = 0; m < num_materials; ++m) w[m] = (*mesh.FindProperty("w" + std::to_string(m)))[v];
  return w;
}

TEST(MaterialsTest, BuiltinSetsAreValidAndPruned) {
  for (int n = 1; n <= 4; ++n) {
    const ReflectanceModel model = BuiltinObjectMaterials(n);
    EXPECT_EQ(int(model.materials.size()), n);
    for (const auto& lobe : model.basis) lobe.Check();
    for (size_t b = 0; b < model.basis.size(); ++b) {  // no unused lobe
      double used = 0;
      for (const auto& m : model.materials) used += m.coefficients[b].sum();
      EXPECT_GT(used, 0);
    }
  }
  // The default three materials include a glossy lobe.
  const ReflectanceModel three = BuiltinObjectMaterials(3);
  bool glossy = false;
  for (const auto& lobe : three.basis) glossy |= lobe.model != BrdfModel::kLambertian;
  EXPECT_TRUE(glossy);
  EXPECT_THROW(BuiltinObjectMaterials(5), UserError);
}

TEST(MaterialsTest, NoisePatternIsAStructuredPartitionOfUnity) {
  TriangleMesh mesh = MakeSphere(20000);
  const ReflectanceModel model = BuiltinObjectMaterials(3);
  WeightPattern pattern;
  pattern.frequency = 3.0;  // cycles per unit on a sphere of radius 1
  AssignMaterialWeights(model, pattern, &mesh);
  std::vector<int> dominant(3, 0);
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    const auto w = WeightsOf(mesh, 3, v);
    double sum = 0;
    for (double x : w) {
      EXPECT_GE(x, 0);
      sum += x;
    }
    EXPECT_NEAR(sum, 1.0, 1e-5);
    ++dominant[std::max_element(w.begin(), w.end()) - w.begin()];
    const Eigen::Vector3d albedo = model.DiffuseAlbedo(w);
    EXPECT_NEAR((*mesh.FindProperty("albedo_r"))[v], albedo.x(), 1e-5);
    EXPECT_NEAR((*mesh.FindProperty("albedo_b"))[v], albedo.z(), 1e-5);
  }
  for (int m = 0; m < 3; ++m) EXPECT_GT(dominant[m], 0.1 * mesh.num_vertices()) << "material " << m;
  // Spatial structure: neighbouring vertices (mesh edges, 0.025 apart; the finest octave's period is
  // 1/24 = 0.042) mostly share the dominant material, random pairs only by chance (about 1/3).
  auto dominant_of = [&](int v) {
    const auto w = WeightsOf(mesh, 3, v);
    return std::max_element(w.begin(), w.end()) - w.begin();
  };
  int same_neighbour = 0, same_random = 0;
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    same_neighbour += dominant_of(mesh.faces[i][0]) == dominant_of(mesh.faces[i][1]);
    same_random += dominant_of(mesh.faces[i][0]) == dominant_of(int((i * 7919) % mesh.num_vertices()));
  }
  EXPECT_GT(double(same_neighbour) / mesh.faces.size(), 0.8);
  EXPECT_LT(double(same_random) / mesh.faces.size(), 0.5);
  // Crisp regions: most vertices are dominated by one material.
  int crisp = 0;
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    const auto w = WeightsOf(mesh, 3, v);
    crisp += *std::max_element(w.begin(), w.end()) > 0.8;
  }
  EXPECT_GT(crisp, 0.5 * mesh.num_vertices());
}

TEST(MaterialsTest, VoronoiAndSinglePatterns) {
  TriangleMesh mesh = MakeSphere(5000);
  const ReflectanceModel model = BuiltinObjectMaterials(4);
  WeightPattern pattern;
  pattern.kind = "voronoi";
  pattern.frequency = 4;
  AssignMaterialWeights(model, pattern, &mesh);
  std::vector<int> dominant(4, 0);
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    const auto w = WeightsOf(mesh, 4, v);
    EXPECT_NEAR(w[0] + w[1] + w[2] + w[3], 1.0, 1e-5);
    ++dominant[std::max_element(w.begin(), w.end()) - w.begin()];
  }
  for (int m = 0; m < 4; ++m) EXPECT_GT(dominant[m], 0);
  pattern.kind = "single";
  AssignMaterialWeights(model, pattern, &mesh);
  for (size_t v = 0; v < mesh.num_vertices(); ++v) EXPECT_EQ(WeightsOf(mesh, 4, v), (std::vector<double>{1, 0, 0, 0}));
  // A smaller model removes the stale weights of the larger one.
  AssignMaterialWeights(BuiltinObjectMaterials(2), pattern, &mesh);
  EXPECT_EQ(mesh.FindProperty("w2"), nullptr);
  EXPECT_EQ(mesh.FindProperty("w3"), nullptr);
  pattern.kind = "stripes";
  EXPECT_THROW(AssignMaterialWeights(model, pattern, &mesh), UserError);
}

}  // namespace
}  // namespace relight
