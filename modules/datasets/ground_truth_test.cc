#include "datasets/ground_truth.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "geometry/mesh_io.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

// A camera model of `names`, one PINHOLE camera each, centres on the x axis.
Reconstruction Cameras(const std::vector<std::string>& names) {
  Reconstruction model;
  uint32_t id = 1;
  for (const auto& name : names) {
    model.cameras[id] = Camera::Pinhole(id, 64, 48, 50.5, 51.25, 32, 24);
    ImageRecord image;
    image.image_id = id;
    image.camera_id = id;
    image.name = name;
    image.SetPose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.25 * id, 0, -3));
    model.images[id] = image;
    ++id;
  }
  return model;
}

// A tiny ground-truth folder: two photos with their lighting, a triangle, materials and one held-out view.
void WriteTinyGroundTruth(const std::string& dir) {
  fs::create_directories(dir + "/relight");
  Cameras({"photo_000.jpg", "photo_001.jpg"}).WriteText(dir);
  Cameras({"view_0"}).WriteText(dir + "/relight");
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0.5f}};
  mesh.faces = {{0, 1, 2}};
  WriteMeshPly(dir + "/mesh.ply", mesh);
  WriteFileAtomic(dir + "/materials.json",
                  R"({"format": "relight-materials", "version": 1,
                      "basis": [{"model": "lambertian"}, {"model": "ggx", "roughness": 0.2, "f0": 0.04}],
                      "materials": [{"name": "red", "coefficients": [[0.7, 0.1, 0.1], [1, 1, 1]]}]})");
  WriteFileAtomic(dir + "/lighting.json",
                  R"({"format": "relight-lighting", "version": 1, "photos": [
                      {"name": "photo_000.jpg", "envmap_latlong": "envmaps/photo_000_latlong.exr",
                       "exposure": 0.25, "white_balance": [1.15, 1.0, 1.08]},
                      {"name": "photo_001.jpg", "envmap_latlong": "envmaps/photo_001_latlong.exr"}]})");
  WriteFileAtomic(dir + "/relight/index.json",
                  R"({"views": ["view_0"], "envmaps": ["sky_0"],
                      "envmap_details": [{"name": "sky_0", "source": "sky", "latlong": "envmaps/sky_0_latlong.exr",
                                          "sun_dir_world": [0, 0.6, 0.8]}],
                      "renders": [{"view": "view_0", "envmap": "sky_0", "image": "view_0__sky_0.exr",
                                   "mask": "view_0_mask.png", "depth": "view_0_depth.exr"}]})");
}

TEST(GroundTruthTest, ReadsEveryFileOfTheLayout) {
  testing::TempDir tmp;
  const std::string ingest = tmp / "ingest";
  WriteTinyGroundTruth(ingest + "/ground_truth");
  const std::optional<GroundTruth> gt = GroundTruth::Open(GroundTruth::OfIngest(ingest).dir());
  ASSERT_TRUE(gt.has_value());
  EXPECT_EQ(gt->dir(), ingest + "/ground_truth");

  ASSERT_TRUE(gt->HasCameras());
  const Reconstruction cameras = gt->ReadCameras();
  ASSERT_EQ(cameras.images.size(), 2u);
  const ImageRecord* photo = cameras.FindImage("photo_001.jpg");
  ASSERT_NE(photo, nullptr);
  EXPECT_NEAR(photo->ProjectionCenter().x(), 0.5, 1e-12);
  EXPECT_NEAR(cameras.cameras.at(photo->camera_id).params[1], 51.25, 1e-12);

  ASSERT_TRUE(gt->HasMesh());
  EXPECT_FALSE(gt->HasOccluders());
  const TriangleMesh mesh = ReadMesh(gt->MeshPath());
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_FLOAT_EQ(mesh.vertices[2].z(), 0.5f);

  const ReflectanceModel materials = gt->ReadMaterials();
  ASSERT_EQ(materials.basis.size(), 2u);
  ASSERT_EQ(materials.materials.size(), 1u);
  EXPECT_DOUBLE_EQ(materials.materials[0].coefficients[0][0], 0.7);

  ASSERT_TRUE(gt->HasLighting());
  const std::vector<TruePhotoLighting> lighting = gt->ReadLighting();
  ASSERT_EQ(lighting.size(), 2u);
  EXPECT_EQ(lighting[0].name, "photo_000.jpg");
  EXPECT_EQ(lighting[0].envmap_latlong, gt->dir() + "/envmaps/photo_000_latlong.exr");
  EXPECT_DOUBLE_EQ(lighting[0].exposure, 0.25);
  EXPECT_DOUBLE_EQ(lighting[0].white_balance[0], 1.15);
  EXPECT_DOUBLE_EQ(lighting[0].white_balance[2], 1.08);
  EXPECT_DOUBLE_EQ(lighting[1].exposure, 1.0);  // absent: 1
  EXPECT_DOUBLE_EQ(lighting[1].white_balance[1], 1.0);

  EXPECT_EQ(gt->DepthPath("photo_000"), gt->dir() + "/depth/photo_000.exr");
  EXPECT_EQ(gt->MaskPath("photo_000"), gt->dir() + "/masks/photo_000.png");
  EXPECT_FALSE(gt->HasLights());

  ASSERT_TRUE(gt->HasHeldout());
  const TrueHeldout heldout = gt->ReadHeldout();
  ASSERT_EQ(heldout.renders.size(), 1u);
  EXPECT_EQ(heldout.renders[0].view, "view_0");
  EXPECT_EQ(heldout.renders[0].envmap, "sky_0");
  const TrueHeldout::Envmap* sky = heldout.FindEnvmap("sky_0");
  ASSERT_NE(sky, nullptr);
  EXPECT_EQ(sky->latlong, gt->dir() + "/relight/envmaps/sky_0_latlong.exr");
  EXPECT_DOUBLE_EQ(sky->details.at("sun_dir_world")[1].get<double>(), 0.6);
  EXPECT_EQ(heldout.FindEnvmap("sky_1"), nullptr);
  EXPECT_NE(gt->ReadHeldoutCameras().FindImage("view_0"), nullptr);
}

TEST(GroundTruthTest, AbsentFolderAndBrokenFilesAreClear) {
  testing::TempDir tmp;
  EXPECT_FALSE(GroundTruth::OfIngest(tmp / "ingest").Exists());
  EXPECT_EQ(GroundTruth::OfIngest(tmp / "ingest").MeshPath(), tmp / "ingest/ground_truth/mesh.ply");
  EXPECT_FALSE(GroundTruth::OfIngest("").Exists());
  EXPECT_FALSE(GroundTruth::OfIngest("").HasCameras());
  EXPECT_FALSE(GroundTruth::Open(tmp / "nothing").has_value());

  const std::string dir = tmp / "gt";
  fs::create_directories(dir);
  const GroundTruth gt = *GroundTruth::Open(dir);
  EXPECT_FALSE(gt.HasCameras());
  EXPECT_FALSE(gt.HasLighting());
  EXPECT_FALSE(gt.HasHeldout());
  // A missing file is named.
  try {
    gt.ReadLighting();
    FAIL() << "no error for a missing lighting.json";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/lighting.json"), std::string::npos) << e.what();
  }
  // A corrupt file and an entry without a map are named too.
  WriteFileAtomic(dir + "/lighting.json", "{\"photos\": [");
  EXPECT_THROW(gt.ReadLighting(), UserError);
  WriteFileAtomic(dir + "/lighting.json", R"({"photos": [{"name": "photo_000.jpg"}]})");
  try {
    gt.ReadLighting();
    FAIL() << "no error for an entry without envmap_latlong";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("envmap_latlong"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("lighting.json"), std::string::npos) << e.what();
  }
  fs::create_directories(dir + "/relight");
  WriteFileAtomic(dir + "/relight/index.json", R"({"views": []})");
  EXPECT_THROW(gt.ReadHeldout(), UserError);
}

}  // namespace
}  // namespace relight
