// The glTF export (relight/gltf_export.h) read back with tinygltf: vertex count, the +Z-up -> +Y-up
// rotation of every position and normal, COLOR_0 against the albedo, triangles per primitive against each
// face's dominant material, roughnessFactor and _ROUGHNESS against the closed forms of docs/FORMATS.md,
// the export gauge and the glTF camera pose.
#include "relight/gltf_export.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <map>

#include "relight/gltf_test_model.h"
#include "relight/views.h"
#include "testing/testing.h"

namespace relight {
namespace {

// The floats of accessor `index` (tightly packed FLOAT data, as the export writes).
std::vector<float> Floats(const tinygltf::Model& g, int index) {
  const tinygltf::Accessor& a = g.accessors.at(index);
  EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
  const tinygltf::BufferView& v = g.bufferViews.at(a.bufferView);
  const int n = tinygltf::GetNumComponentsInType(uint32_t(a.type));
  std::vector<float> out(a.count * n);
  std::memcpy(out.data(), g.buffers.at(v.buffer).data.data() + v.byteOffset + a.byteOffset, out.size() * 4);
  return out;
}

std::vector<uint32_t> Indices(const tinygltf::Model& g, int index) {
  const tinygltf::Accessor& a = g.accessors.at(index);
  EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
  const tinygltf::BufferView& v = g.bufferViews.at(a.bufferView);
  std::vector<uint32_t> out(a.count);
  std::memcpy(out.data(), g.buffers.at(v.buffer).data.data() + v.byteOffset + a.byteOffset, out.size() * 4);
  return out;
}

tinygltf::Model Load(const std::string& path) {
  tinygltf::Model g;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  EXPECT_TRUE(loader.LoadBinaryFromFile(&g, &err, &warn, path)) << err;
  EXPECT_TRUE(err.empty()) << err;
  EXPECT_TRUE(warn.empty()) << warn;
  return g;
}

double Lum(const Eigen::Vector3d& c) { return 0.2126 * c.x() + 0.7152 * c.y() + 0.0722 * c.z(); }

TEST(GltfExport, RoughnessClosedForms) {
  EXPECT_EQ(LobeAlpha(BrdfLobe{}), 1.0);
  EXPECT_NEAR(LobeAlpha(BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 50}), std::sqrt(2.0 / 52), 1e-15);
  EXPECT_EQ(LobeAlpha(BrdfLobe{BrdfModel::kPhong, 0.3, 0.04, 0}), 1.0);
  EXPECT_EQ(LobeAlpha(BrdfLobe{BrdfModel::kGgx, 0.2, 0.04, 50}), 0.2);
  EXPECT_EQ(LobeAlpha(BrdfLobe{BrdfModel::kCookTorrance, 0.35, 0.04, 50}), 0.35);
  const gltf_testing::TestModel t = gltf_testing::MakeTestModel();
  const double r_phong = std::sqrt(std::sqrt(2.0 / 52)), r_ggx = std::sqrt(0.2);
  EXPECT_EQ(MaterialGltfRoughness(t.reflectance, 0), 1.0);  // Lambertian only
  EXPECT_NEAR(MaterialGltfRoughness(t.reflectance, 1), r_phong, 1e-15);
  EXPECT_NEAR(MaterialGltfRoughness(t.reflectance, 2), (0.1 * r_phong + 0.5 * r_ggx) / 0.6, 1e-15);
  EXPECT_NEAR(MaterialGltfRoughness(t.reflectance, 3), r_ggx, 1e-15);
}

TEST(GltfExport, GlbReadsBackWithFrameColoursPrimitivesAndRoughness) {
  const gltf_testing::TestModel t = gltf_testing::MakeTestModel();
  const TriangleMesh& mesh = t.mesh;
  testing::TempDir dir;
  const GltfModelSummary s = WriteModelGlb(dir / "model.glb", mesh, t.reflectance);
  const tinygltf::Model g = Load(dir / "model.glb");
  EXPECT_EQ(g.asset.version, "2.0");
  ASSERT_EQ(g.meshes.size(), 1u);
  ASSERT_EQ(g.materials.size(), 4u);
  ASSERT_EQ(g.nodes.size(), 1u);
  EXPECT_TRUE(g.nodes[0].matrix.empty() && g.nodes[0].rotation.empty());  // the frame is in the positions

  // Expected dominant material per face: the largest mean weight (computed here from the weights directly).
  std::vector<std::vector<uint32_t>> expected(4);
  for (const auto& f : mesh.faces) {
    int best = 0;
    double best_w = -1;
    for (int m = 0; m < 4; ++m) {
      const std::vector<float>& w = *mesh.FindProperty("w" + std::to_string(m));
      const double mean = (double(w[f[0]]) + w[f[1]] + w[f[2]]) / 3;
      if (mean > best_w) best_w = mean, best = m;
    }
    for (int c = 0; c < 3; ++c) expected[best].push_back(uint32_t(f[c]));
  }
  ASSERT_TRUE(expected[3].empty()) << "the test model's 'unused' material must not dominate";
  for (int m = 0; m < 3; ++m) ASSERT_FALSE(expected[m].empty()) << m;

  // One primitive per used material, each holding exactly that material's faces; shared vertex attributes.
  const auto& prims = g.meshes[0].primitives;
  ASSERT_EQ(prims.size(), 3u);
  EXPECT_EQ(s.primitives, 3);
  size_t triangles = 0;
  for (const auto& p : prims) {
    EXPECT_EQ(p.mode, TINYGLTF_MODE_TRIANGLES);
    ASSERT_TRUE(p.material >= 0 && p.material < 3) << p.material;
    EXPECT_EQ(Indices(g, p.indices), expected[p.material]) << "material " << p.material;
    EXPECT_EQ(s.triangles_per_material[p.material] * 3, int(expected[p.material].size()));
    EXPECT_EQ(p.attributes, prims[0].attributes);
    triangles += g.accessors[p.indices].count / 3;
  }
  EXPECT_EQ(triangles, mesh.num_faces());

  // Vertices: count, and the rotation (x, y, z) -> (x, z, -y) of every position and normal.
  const auto& attr = prims[0].attributes;
  for (const char* key : {"POSITION", "NORMAL", "COLOR_0", "_ROUGHNESS"}) ASSERT_TRUE(attr.count(key)) << key;
  EXPECT_EQ(g.accessors[attr.at("POSITION")].count, mesh.num_vertices());
  const std::vector<float> pos = Floats(g, attr.at("POSITION")), nrm = Floats(g, attr.at("NORMAL"));
  const std::vector<float> col = Floats(g, attr.at("COLOR_0")), rough = Floats(g, attr.at("_ROUGHNESS"));
  ASSERT_EQ(col.size(), 3 * mesh.num_vertices());
  ASSERT_EQ(rough.size(), mesh.num_vertices());
  const Eigen::Vector3f p0 = mesh.vertices[0];
  EXPECT_EQ(pos[0], p0.x());
  EXPECT_EQ(pos[1], p0.z());
  EXPECT_EQ(pos[2], -p0.y());
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    const Eigen::Vector3f& p = mesh.vertices[v];
    const Eigen::Vector3f n = mesh.normals[v].normalized();
    EXPECT_EQ(Eigen::Vector3f(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]), Eigen::Vector3f(p.x(), p.z(), -p.y()));
    EXPECT_LT(
        (Eigen::Vector3f(nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]) - Eigen::Vector3f(n.x(), n.z(), -n.y())).norm(),
        1e-6f);
  }
  // POSITION bounds (required by glTF).
  const tinygltf::Accessor& pa = g.accessors[attr.at("POSITION")];
  ASSERT_EQ(pa.minValues.size(), 3u);
  const Eigen::AlignedBox3f box = mesh.BoundingBox();
  EXPECT_NEAR(pa.minValues[1], box.min().z(), 1e-7);
  EXPECT_NEAR(pa.maxValues[2], -box.min().y(), 1e-7);

  // COLOR_0 is the linear albedo clamped to [0, 1] (gauge 1 here).
  const char* albedo[3] = {"albedo_r", "albedo_g", "albedo_b"};
  for (size_t v = 0; v < mesh.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(col[3 * v + c], std::clamp((*mesh.FindProperty(albedo[c]))[v], 0.0f, 1.0f), 1e-6) << v << " " << c;
  EXPECT_EQ(col[3 * 7], 1.0f);  // albedo_r 1.5

  // Materials: metallic 0, base colour factor 1, roughness from the lobes.
  for (int m = 0; m < 4; ++m) {
    const auto& pbr = g.materials[m].pbrMetallicRoughness;
    EXPECT_EQ(g.materials[m].name, t.reflectance.materials[m].name);
    EXPECT_EQ(pbr.metallicFactor, 0.0);
    EXPECT_EQ(pbr.baseColorFactor, std::vector<double>({1, 1, 1, 1}));
    EXPECT_NEAR(pbr.roughnessFactor, MaterialGltfRoughness(t.reflectance, m), 1e-12) << m;
  }
  EXPECT_EQ(g.materials[0].pbrMetallicRoughness.roughnessFactor, 1.0);

  // _ROUGHNESS: sqrt(alpha) of the glossy lobes weighted by their blended coefficients' luminance.
  const double r_phong = std::sqrt(std::sqrt(2.0 / 52)), r_ggx = std::sqrt(0.2);
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    double s_phong = 0, s_ggx = 0;
    for (int m = 0; m < 4; ++m) {
      const double w = (*mesh.FindProperty("w" + std::to_string(m)))[v];
      s_phong += w * Lum(t.reflectance.materials[m].coefficients[1]);
      s_ggx += w * Lum(t.reflectance.materials[m].coefficients[2]);
    }
    EXPECT_NEAR(rough[v], (s_phong * r_phong + s_ggx * r_ggx) / (s_phong + s_ggx), 1e-6) << v;
  }
}

TEST(GltfExport, GaugeScalesAlbedoIntoRangeAndColoursFollow) {
  std::vector<Eigen::Vector3f> albedo(1000);
  for (size_t v = 0; v < albedo.size(); ++v) albedo[v] = Eigen::Vector3f(0.1f, 3.0f * v / 999, 0.2f);
  // The 99.5th percentile of the largest channel (nearest rank) of 0 ... 3.
  EXPECT_NEAR(ExportAlbedoScale(albedo), 3.0 * 994 / 999, 1e-6);
  for (auto& a : albedo) a *= 0.3f;
  EXPECT_EQ(ExportAlbedoScale(albedo), 1.0);  // never brightened

  gltf_testing::TestModel t = gltf_testing::MakeTestModel();
  testing::TempDir dir;
  WriteModelGlb(dir / "model.glb", t.mesh, t.reflectance, 2.0);
  const tinygltf::Model g = Load(dir / "model.glb");
  const std::vector<float> col = Floats(g, g.meshes[0].primitives[0].attributes.at("COLOR_0"));
  EXPECT_NEAR(col[3 * 7], 0.75, 1e-6);  // 1.5 / 2
  EXPECT_NEAR(col[3 * 3 + 1], (*t.mesh.FindProperty("albedo_g"))[3] / 2, 1e-6);

  // Without albedo_r/g/b the colours are the Lambertian coefficients blended by the weights.
  t.mesh.properties.erase(std::remove_if(t.mesh.properties.begin(), t.mesh.properties.end(),
                                         [](const auto& p) { return p.first.rfind("albedo_", 0) == 0; }),
                          t.mesh.properties.end());
  WriteModelGlb(dir / "plain.glb", t.mesh, t.reflectance);
  const tinygltf::Model h = Load(dir / "plain.glb");
  const std::vector<float> plain = Floats(h, h.meshes[0].primitives[0].attributes.at("COLOR_0"));
  for (size_t v : {0, 5, 40}) {
    std::vector<double> w;
    for (int m = 0; m < 4; ++m) w.push_back((*t.mesh.FindProperty("w" + std::to_string(m)))[v]);
    const Eigen::Vector3d a = t.reflectance.DiffuseAlbedo(w);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(plain[3 * v + c], std::min(1.0, a[c]), 1e-6);
  }
}

TEST(GltfExport, CameraPoseInGltfFrame) {
  const RenderCamera v = OrbitCamera("v", Eigen::Vector3d(0.2, -0.1, 0.4), 0.5, 35, 20, 64, 40, 0.8);
  const Eigen::Matrix4d m = GltfWorldFromCamera(v.pose);
  const Eigen::Vector3d c = v.pose.ProjectionCenter();
  EXPECT_NEAR((m.topRightCorner<3, 1>() - Eigen::Vector3d(c.x(), c.z(), -c.y())).norm(), 0, 1e-12);
  // The glTF camera looks along its -z: the world viewing direction, rotated into glTF.
  const Eigen::Vector3d d = v.pose.ViewingDirection();
  EXPECT_NEAR((-m.block<3, 1>(0, 2) - Eigen::Vector3d(d.x(), d.z(), -d.y())).norm(), 0, 1e-12);
  // Its +y is world up in the image (OrbitCamera keeps +Z up): positive glTF +Y component.
  EXPECT_GT(m(1, 1), 0.5);
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  EXPECT_NEAR((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(r.determinant(), 1, 1e-12);
}

TEST(GltfExport, CamerasAreNodesWithTheirPoseAndFieldOfView) {
  const gltf_testing::TestModel t = gltf_testing::MakeTestModel();
  testing::TempDir dir;
  std::vector<RenderCamera> cameras = {
      OrbitCamera("photo_a.jpg", Eigen::Vector3d(0.1, -0.3, 0.6), 0.5, 35, 20, 64, 40, 0.8),
      OrbitCamera("photo_b.jpg", Eigen::Vector3d(0.1, -0.3, 0.6), 0.5, 200, 50, 80, 60, 0.8)};
  cameras[1].camera.height = 60;  // not square: aspect 80 / 60
  const GltfModelSummary s = WriteModelGlb(dir / "model.glb", t.mesh, t.reflectance, 1.0, cameras);
  EXPECT_EQ(s.cameras, 2);
  const tinygltf::Model g = Load(dir / "model.glb");
  ASSERT_EQ(g.cameras.size(), 2u);
  ASSERT_EQ(g.nodes.size(), 3u);
  ASSERT_EQ(g.scenes.at(0).nodes.size(), 3u);
  for (int k = 0; k < 2; ++k) {
    const tinygltf::Node& n = g.nodes[k + 1];
    EXPECT_EQ(n.name, cameras[k].name);
    ASSERT_EQ(n.camera, k);
    ASSERT_EQ(n.matrix.size(), 16u);
    const Eigen::Matrix4d expected = GltfWorldFromCamera(cameras[k].pose);
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) EXPECT_NEAR(n.matrix[col * 4 + row], expected(row, col), 1e-12);
    const tinygltf::Camera& c = g.cameras[k];
    EXPECT_EQ(c.type, "perspective");
    // The vertical field of view of a pinhole of focal fy over the image height.
    EXPECT_NEAR(c.perspective.yfov, 2 * std::atan(0.5 * cameras[k].camera.height / cameras[k].camera.FocalY()), 1e-12);
    EXPECT_NEAR(c.perspective.aspectRatio, double(cameras[k].camera.width) / cameras[k].camera.height, 1e-12);
    EXPECT_GT(c.perspective.znear, 0);
  }
}

}  // namespace
}  // namespace relight
