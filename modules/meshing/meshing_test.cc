// Mesh clean-up tests: damaged spheres and hemispheres whose true surface is
// known (unit sphere), the Stanford bunny, cropping, and the stage end to end.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#include "core/error.h"
#include "core/json.h"
#include "geometry/mesh_io.h"
#include "geometry/primitives.h"
#include "meshing/geometry_views.h"
#include "meshing/mesh_cleanup.h"
#include "meshing/mesh_stage.h"
#include "testing/testing.h"

namespace relight {
namespace {

// Adds what real reconstructions contain: radial noise, holes, floating
// fragments, a non-manifold fin, duplicate vertices, degenerate faces, and
// some faces with flipped orientation.
void Damage(TriangleMesh* m, bool holes, uint32_t seed) {
  m->normals.clear();  // a reconstruction's soup has none
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.004f, 0.004f);
  for (auto& v : m->vertices) v *= 1.0f + noise(rng);
  if (holes) {
    // Three holes: faces whose centroid is near a point of the sphere (~10-40 boundary edges each).
    const Eigen::Vector3f centres[] = {Eigen::Vector3f(1, 0.2f, 0.1f).normalized(),
                                       Eigen::Vector3f(-0.3f, 1, 0.2f).normalized(),
                                       Eigen::Vector3f(0.1f, -0.4f, -1).normalized()};
    std::vector<Eigen::Vector3i> kept;
    for (const auto& f : m->faces) {
      const Eigen::Vector3f c = (m->vertices[f[0]] + m->vertices[f[1]] + m->vertices[f[2]]) / 3.0f;
      bool in_hole = false;
      for (const auto& h : centres) in_hole |= (c.normalized() - h).norm() < 0.09f;
      if (!in_hole) kept.push_back(f);
    }
    m->faces = kept;
  }
  // Floating fragments: small closed tetrahedra and a loose triangle strip.
  for (int k = 0; k < 6; ++k) {
    const Eigen::Vector3f c(1.5f + 0.2f * k, 0.3f * k - 0.5f, 0.1f * k);
    const int base = static_cast<int>(m->vertices.size());
    const float s = 0.03f;
    m->vertices.push_back(c + Eigen::Vector3f(s, s, s));
    m->vertices.push_back(c + Eigen::Vector3f(s, -s, -s));
    m->vertices.push_back(c + Eigen::Vector3f(-s, s, -s));
    m->vertices.push_back(c + Eigen::Vector3f(-s, -s, s));
    m->faces.push_back({base, base + 1, base + 2});
    m->faces.push_back({base, base + 3, base + 1});
    m->faces.push_back({base, base + 2, base + 3});
    m->faces.push_back({base + 1, base + 3, base + 2});
  }
  // A non-manifold fin: a third face on an existing edge.
  {
    const auto f = m->faces[100];
    m->vertices.push_back(m->vertices[f[0]] * 1.2f);
    m->faces.push_back({f[0], f[1], static_cast<int>(m->vertices.size()) - 1});
  }
  // Duplicate vertices: unweld a patch of faces (same positions, new indices).
  for (size_t i = 200; i < 260 && i < m->faces.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      m->vertices.push_back(m->vertices[m->faces[i][k]]);
      m->faces[i][k] = static_cast<int>(m->vertices.size()) - 1;
    }
  }
  // Degenerate faces: repeated index, and collinear points.
  m->faces.push_back({5, 5, 6});
  {
    const int a = m->faces[300][0], b = m->faces[300][1];
    m->vertices.push_back(0.5f * (m->vertices[a] + m->vertices[b]));
    m->faces.push_back({a, b, static_cast<int>(m->vertices.size()) - 1});
  }
  // Flip a block of faces (inconsistent orientation).
  for (size_t i = 400; i < 450 && i < m->faces.size(); ++i) std::swap(m->faces[i][1], m->faces[i][2]);
}

double FractionOutward(const TriangleMesh& m, const Eigen::Vector3f& centre) {
  int outward = 0;
  for (size_t v = 0; v < m.vertices.size(); ++v) outward += m.normals[v].dot(m.vertices[v] - centre) > 0;
  return double(outward) / m.vertices.size();
}

double MaxRadialError(const TriangleMesh& m) {
  double e = 0;
  for (const auto& v : m.vertices) e = std::max(e, std::abs(double(v.norm()) - 1.0));
  return e;
}

TEST(MeshCleanup, DamagedSphereBecomesOneClosedManifoldWithTheRequestedVertexCount) {
  TriangleMesh input = MakeIcosphere(5);
  Damage(&input, /*holes=*/true, 1);
  ASSERT_FALSE(FindManifoldViolation(input).empty());
  ASSERT_GT(CountComponents(input), 6);
  for (int target : {3000, 8000}) {
    MeshCleanupOptions options;
    options.target_vertices = target;
    MeshCleanupSummary summary;
    const TriangleMesh out = CleanMesh(input, options, "damaged sphere", &summary);
    SCOPED_TRACE("target " + std::to_string(target));
    EXPECT_EQ(FindManifoldViolation(out), "");
    EXPECT_EQ(CountComponents(out), 1);
    EXPECT_EQ(CountBoundaryEdges(out), 0u) << "the three holes are small and must be filled";
    EXPECT_TRUE(summary.closed);
    EXPECT_EQ(summary.holes_filled, 3);
    EXPECT_GE(summary.components_removed, 6);  // the tetrahedra (and the split-off fin)
    EXPECT_GT(summary.duplicate_points_merged, 0u);
    EXPECT_NEAR(double(out.vertices.size()), target, 0.10 * target);
    EXPECT_GT(FractionOutward(out, Eigen::Vector3f::Zero()), 0.999);
    // The surface stays on the unit sphere: noise 0.4%, hole fill and remeshing within 3%.
    EXPECT_LT(MaxRadialError(out), 0.03);
  }
}

TEST(MeshCleanup, InvalidInputIsRepairedBeforeRemeshing) {
  // Issue 34: CGAL's isotropic remeshing segfaulted on a poor surface. Here a sphere carries what makes it
  // crash or misbehave: one vertex pulled through to the far side (its fan pierces the surface), a face on a NaN
  // vertex, a face with an index out of range and a zero-area face, cleaned with hole filling as loose as
  // configs/temple.yaml's. The result must be a finite manifold near the sphere, and the summary must count
  // what was removed.
  TriangleMesh input = MakeIcosphere(4);
  const int n = static_cast<int>(input.vertices.size());
  input.vertices[0] *= -1.3f;  // its fan now spans the sphere and pierces the far side
  input.vertices.emplace_back(std::nanf(""), 0.0f, 0.0f);
  input.faces.emplace_back(1, 2, n);
  input.faces.emplace_back(1, 2, n + 100);
  input.faces.emplace_back(3, 3, 4);
  MeshCleanupOptions options;
  options.target_vertices = 1500;
  options.max_hole_edges = 5000;
  options.max_hole_fraction = 1.0;
  MeshCleanupSummary summary;
  const TriangleMesh out = CleanMesh(input, options, "pierced sphere", &summary);
  EXPECT_GE(summary.invalid_faces_removed, 2u);  // the NaN face and the out-of-range face
  EXPECT_GE(summary.self_intersecting_faces_removed, 2u);  // the fan and the far-side faces it crosses
  for (const auto& v : out.vertices) ASSERT_TRUE(v.allFinite());
  EXPECT_EQ(FindManifoldViolation(out), "");
  EXPECT_NEAR(double(out.vertices.size()), 1500, 150);
  EXPECT_LT(MaxRadialError(out), 0.05);
}

TEST(MeshCleanup, InwardSphereIsTurnedOutward) {
  TriangleMesh input = MakeIcosphere(4);
  for (auto& f : input.faces) std::swap(f[1], f[2]);
  MeshCleanupOptions options;
  options.target_vertices = 2000;
  MeshCleanupSummary summary;
  const TriangleMesh out = CleanMesh(input, options, "inward sphere", &summary);
  EXPECT_TRUE(summary.orientation_reversed);
  EXPECT_GT(FractionOutward(out, Eigen::Vector3f::Zero()), 0.999);
  EXPECT_NEAR(double(out.vertices.size()), 2000, 200);
}

TEST(MeshCleanup, DecimationReachesTheVertexBudget) {
  TriangleMesh input = MakeIcosphere(5);
  Damage(&input, /*holes=*/false, 2);
  MeshCleanupOptions options;
  options.target_vertices = 2500;
  options.remesh = false;
  MeshCleanupSummary summary;
  const TriangleMesh out = CleanMesh(input, options, "sphere", &summary);
  EXPECT_EQ(FindManifoldViolation(out), "");
  EXPECT_EQ(CountComponents(out), 1);
  EXPECT_NEAR(double(out.vertices.size()), 2500, 250);
  EXPECT_LT(MaxRadialError(out), 0.03);
}

TEST(MeshCleanup, ComponentsRankByTheDataNearThemNotByArea) {
  // A unit sphere (area 12.6) and, beside it, a larger sphere of radius 2
  // (area 50) with no data near it: the Poisson underside of a cropped ground
  // sheet is such a part. The data points lie on the unit sphere.
  TriangleMesh input = MakeIcosphere(3);
  const TriangleMesh big = MakeIcosphere(3);
  const int offset = static_cast<int>(input.vertices.size());
  for (const auto& v : big.vertices) input.vertices.push_back(2.0f * v + Eigen::Vector3f(6, 0, 0));
  for (const auto& f : big.faces) input.faces.push_back(f + Eigen::Vector3i::Constant(offset));
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < offset; ++i) points.push_back(1.01 * input.vertices[i].cast<double>());

  MeshCleanupOptions options;
  options.target_vertices = 0;
  MeshCleanupSummary by_area;
  const TriangleMesh largest = CleanMesh(input, options, "two spheres", &by_area);
  EXPECT_EQ(by_area.component_ranking, "area");
  EXPECT_EQ(by_area.components_found, 2);
  for (const auto& v : largest.vertices) EXPECT_NEAR((v - Eigen::Vector3f(6, 0, 0)).norm(), 2.0f, 1e-4f);

  options.support_points = &points;
  options.support_radius = 0.1;
  MeshCleanupSummary by_support;
  const TriangleMesh supported = CleanMesh(input, options, "two spheres", &by_support);
  EXPECT_EQ(by_support.component_ranking, "support");
  EXPECT_EQ(by_support.components_removed, 1);
  EXPECT_EQ(supported.vertices.size(), size_t(offset));
  for (const auto& v : supported.vertices) EXPECT_NEAR(v.norm(), 1.0f, 1e-4f);

  // Data far from every vertex (beyond the radius): back to area.
  std::vector<Eigen::Vector3d> far = {Eigen::Vector3d(0, 0, 10)};
  options.support_points = &far;
  MeshCleanupSummary no_support;
  CleanMesh(input, options, "two spheres", &no_support);
  EXPECT_EQ(no_support.component_ranking, "area");
}

// Upper hemisphere (z > 0) of a damaged sphere: an open, bounded surface.
TriangleMesh DamagedDome(bool inward) {
  TriangleMesh sphere = MakeIcosphere(5);
  std::vector<Eigen::Vector3i> faces;
  for (const auto& f : sphere.faces) {
    if (sphere.vertices[f[0]].z() > 0 && sphere.vertices[f[1]].z() > 0 && sphere.vertices[f[2]].z() > 0) {
      faces.push_back(inward ? Eigen::Vector3i(f[0], f[2], f[1]) : f);
    }
  }
  sphere.faces = faces;
  Damage(&sphere, /*holes=*/false, 3);
  return sphere;
}

TEST(MeshCleanup, DomeStaysOpenAndBoundedAndIsOrientedTowardsTheCameras) {
  const TriangleMesh input = DamagedDome(/*inward=*/true);
  MeshCleanupOptions options;
  options.target_vertices = 3000;
  MeshCleanupSummary summary;
  TriangleMesh out = CleanMesh(input, options, "dome", &summary);
  EXPECT_EQ(FindManifoldViolation(out), "");
  EXPECT_EQ(CountComponents(out), 1);
  EXPECT_GT(CountBoundaryEdges(out), 50u) << "the rim is a large boundary and stays open";
  EXPECT_FALSE(summary.closed);
  EXPECT_NEAR(double(out.vertices.size()), 3000, 300);

  // Cameras above the dome, looking down at it.
  Reconstruction cameras;
  cameras.cameras[1] = Camera::Pinhole(1, 640, 480, 500, 500, 320, 240);
  for (int i = 0; i < 8; ++i) {
    const double a = 2 * M_PI * i / 8;
    const Eigen::Vector3d centre(3 * std::cos(a), 3 * std::sin(a), 2.5);
    const Eigen::Vector3d z = (-centre).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d r;
    r.row(0) = x;
    r.row(1) = y;
    r.row(2) = z;
    ImageRecord im;
    im.image_id = i + 1;
    im.camera_id = 1;
    im.name = "view" + std::to_string(i);
    im.SetPose(r, centre);
    cameras.images[im.image_id] = im;
  }
  std::string method;
  TriangleMesh by_cameras = out;
  OrientOutward(&cameras, &by_cameras, &method);
  EXPECT_EQ(method, "cameras");
  EXPECT_GT(FractionOutward(by_cameras, Eigen::Vector3f::Zero()), 0.99);
  TriangleMesh by_centroid = out;
  OrientOutward(nullptr, &by_centroid, &method);
  EXPECT_EQ(method, "centroid");
  EXPECT_GT(FractionOutward(by_centroid, Eigen::Vector3f::Zero()), 0.99);
}

TEST(MeshCleanup, StanfordBunny) {
  const std::string path = testing::SharedDataDir() + "/meshes/stanford-bunny.obj";
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " is part of the shared test data";
  const TriangleMesh input = ReadMesh(path);
  MeshCleanupOptions options;
  options.target_vertices = 10000;
  MeshCleanupSummary summary;
  const TriangleMesh out = CleanMesh(input, options, path, &summary);
  EXPECT_EQ(FindManifoldViolation(out), "");
  EXPECT_EQ(CountComponents(out), 1);
  EXPECT_NEAR(double(out.vertices.size()), 10000, 1000);
  // Outward: the signed volume of a closed outward surface is positive; for an open one, faces
  // point away from the centroid on average.
  double volume = 0;
  for (const auto& f : out.faces) {
    volume += out.vertices[f[0]].cast<double>().dot(
                  out.vertices[f[1]].cast<double>().cross(out.vertices[f[2]].cast<double>())) /
              6.0;
  }
  if (summary.closed) {
    EXPECT_GT(volume, 0);
  }
  TriangleMesh copy = out;
  std::string method;
  EXPECT_FALSE(OrientOutward(nullptr, &copy, &method)) << "already outward";
}

TEST(MeshCrop, BoxAndViews) {
  const TriangleMesh sphere = MakeIcosphere(3);
  CropRegion region;
  region.use_box = true;
  region.box = Eigen::AlignedBox3d(Eigen::Vector3d(-2, -2, 0), Eigen::Vector3d(2, 2, 2));
  size_t by_box = 0, by_views = 0;
  const TriangleMesh top = CropMesh(sphere, region, &by_box, &by_views);
  EXPECT_EQ(top.faces.size() + by_box, sphere.faces.size());
  EXPECT_NEAR(double(top.faces.size()), sphere.faces.size() / 2.0, 0.05 * sphere.faces.size());
  for (const auto& v : top.vertices) EXPECT_GT(v.z(), -0.2f);
  // One camera on +X looking at the origin sees (in its frustum) only part of the sphere's surroundings.
  Reconstruction cameras;
  cameras.cameras[1] = Camera::Pinhole(1, 100, 100, 200, 200, 50, 50);  // tan(half field of view) = 0.25
  ImageRecord im;
  im.image_id = 1;
  im.camera_id = 1;
  Eigen::Matrix3d r;
  r << 0, 1, 0, 0, 0, -1, -1, 0, 0;  // looks along -X
  im.SetPose(r, Eigen::Vector3d(1.5, 0, 0));
  cameras.images[1] = im;
  CropRegion views;
  views.cameras = &cameras;
  views.min_views = 1;
  const TriangleMesh seen = CropMesh(sphere, views, &by_box, &by_views);
  EXPECT_GT(by_views, sphere.faces.size() / 2);
  EXPECT_GT(seen.faces.size(), 0u);
  for (size_t f = 0; f < seen.faces.size(); ++f) {
    const Eigen::Vector3f c =
        (seen.vertices[seen.faces[f][0]] + seen.vertices[seen.faces[f][1]] + seen.vertices[seen.faces[f][2]]) / 3.0f;
    EXPECT_LT(c.x(), 1.5f);
    EXPECT_LE(std::abs(c.y()), 0.25f * (1.5f - c.x()) + 1e-3f);  // inside the frustum
    EXPECT_LE(std::abs(c.z()), 0.25f * (1.5f - c.x()) + 1e-3f);
  }
}

TEST(MeshCrop, SparseBoxKeepsAnObjectStandingOnATexturedGround) {
  // The typical capture: 950 sparse points on a 10 x 10 ground (z = 0), 50 on
  // a 1-high object at the centre, and 10 far outliers. The vertical 98th
  // percentile lands at z = 0.78, inside the object; a margin of 15% of that
  // axis' own extent would crop the object's top at z = 0.9.
  Reconstruction model;
  uint64_t id = 1;
  auto add = [&](double x, double y, double z) {
    Point3D p;
    p.point3d_id = id;
    p.xyz = Eigen::Vector3d(x, y, z);
    model.points3d[id++] = p;
  };
  for (int i = 0; i < 950; ++i) add(-5 + 10.0 * (i % 31) / 30, -5 + 10.0 * (i / 31) / 30, 0.0);
  for (int i = 1; i <= 50; ++i) add(0.1 * std::cos(i), 0.1 * std::sin(i), i / 50.0);
  for (int i = 0; i < 10; ++i) add(100.0 + i, 100.0, 100.0);
  const Eigen::AlignedBox3d box = SparsePointBox(model, 2.0, 0.15);
  ASSERT_FALSE(box.isEmpty());
  // Grown by 15% of the largest side (about 10) on every axis: the object's top is in, the outliers are out.
  EXPECT_GT(box.max().z(), 1.0 + 0.1);
  EXPECT_NEAR(box.max().z() - box.min().z(), 0.78 + 2 * 0.15 * 10, 0.05);
  EXPECT_NEAR(box.max().x(), 5.0 + 0.15 * 10, 0.05);
  EXPECT_LT(box.max().x(), 10.0);
  EXPECT_LT(box.max().y(), 10.0);
}

TEST(MeshCrop, DistanceToPoints) {
  // Data points only on the upper cap (z > 0.5): faces far from them go.
  const TriangleMesh sphere = MakeIcosphere(4);
  std::vector<Eigen::Vector3d> points;
  for (const auto& v : sphere.vertices) {
    if (v.z() > 0.5f) points.push_back(v.cast<double>());
  }
  CropRegion region;
  region.points = &points;
  region.max_distance = 0.1;
  size_t by_box = 0, by_views = 0, by_distance = 0;
  const TriangleMesh kept = CropMesh(sphere, region, &by_box, &by_views, &by_distance);
  EXPECT_EQ(kept.faces.size() + by_distance, sphere.faces.size());
  EXPECT_GT(by_distance, sphere.faces.size() / 2);
  for (const auto& v : kept.vertices) {
    // Conservative grid test: kept faces lie within 2·√3 cells of a point.
    EXPECT_GT(v.z(), 0.5f - 2 * std::sqrt(3.0f) * 0.1f - 0.1f);
  }
  for (const auto& v : sphere.vertices) {
    if (v.z() > 0.55f) {
      bool found = false;
      for (const auto& k : kept.vertices) found |= (k - v).norm() < 1e-6f;
      EXPECT_TRUE(found) << "a vertex near the data was cropped";
      break;
    }
  }
}

TEST(MeshStage, FileSourceEndToEnd) {
  testing::TempDir dir;
  TriangleMesh input = MakeIcosphere(5);
  Damage(&input, true, 4);
  WriteMeshPly(dir / "noisy.ply", input, /*binary=*/false);
  MeshOptions options;
  options.source = "file";
  options.file = dir / "noisy.ply";
  options.target_vertices = 4000;
  std::filesystem::create_directories(dir / "out");
  const MeshSummary s = RunMesh(options, MeshInputs{}, dir / "out");
  EXPECT_TRUE(s.manifold);
  EXPECT_EQ(s.components, 1);
  EXPECT_EQ(s.boundary_edges, 0u);
  const TriangleMesh out = ReadMesh(dir / "out/mesh.ply");
  EXPECT_NEAR(double(out.vertices.size()), 4000, 400);
  ASSERT_EQ(out.normals.size(), out.vertices.size());
  EXPECT_GT(FractionOutward(out, Eigen::Vector3f::Zero()), 0.999);
  const Json j = ReadJsonFile(dir / "out/mesh_summary.json");
  EXPECT_EQ(j.at("output_vertices").get<size_t>(), out.vertices.size());
  EXPECT_EQ(j.at("cleanup").at("holes_filled").get<int>(), 3);
  EXPECT_TRUE(j.at("manifold").get<bool>());
}

TEST(MeshStage, GroundTruthIsPassedThroughWithItsProperties) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "ingest/ground_truth");
  TriangleMesh object = MakeIcosphere(2);
  auto& w0 = object.Property("w0");
  for (size_t i = 0; i < w0.size(); ++i) w0[i] = float(i) / w0.size();
  WriteMeshPly(dir / "ingest/ground_truth/mesh.ply", object);
  TriangleMesh ground;
  ground.vertices = {{-5, -5, -1}, {5, -5, -1}, {5, 5, -1}, {-5, 5, -1}};
  ground.faces = {{0, 1, 2}, {0, 2, 3}};
  WriteMeshPly(dir / "ingest/ground_truth/occluders.ply", ground);
  MeshOptions options;
  options.source = "ground_truth";
  std::filesystem::create_directories(dir / "out");
  MeshInputs inputs;  // as the stage's main resolves the source
  inputs.known_mesh = dir / "ingest/ground_truth/mesh.ply";
  inputs.known_occluders = dir / "ingest/ground_truth/occluders.ply";
  const MeshSummary s = RunMesh(options, inputs, dir / "out");
  EXPECT_FALSE(s.cleaned);
  const TriangleMesh out = ReadMesh(dir / "out/mesh.ply");
  ASSERT_EQ(out.vertices.size(), object.vertices.size());
  ASSERT_NE(out.FindProperty("w0"), nullptr);
  EXPECT_EQ(*out.FindProperty("w0"), w0);
  EXPECT_EQ(out.normals.size(), out.vertices.size());
  EXPECT_EQ(ReadMesh(dir / "out/occluders.ply").faces.size(), 2u);
}

TEST(MeshStage, ClearErrors) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "out");
  MeshOptions options;  // source mvs without an mvs stage
  try {
    RunMesh(options, MeshInputs{}, dir / "out");
    FAIL() << "expected a UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("mvs"), std::string::npos) << e.what();
  }
  options.source = "file";
  options.file = dir / "missing.ply";
  try {
    RunMesh(options, MeshInputs{}, dir / "out");
    FAIL() << "expected a UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.ply"), std::string::npos) << e.what();
  }
}


// The geometry views: a unit sphere 5 units in front of a 200 x 200 pinhole camera (f = 200 px) projects to a
// disc of radius f R / sqrt(d^2 - R^2) = 40.82 px; the clay render covers that disc and nothing else, and dots
// of points on the sphere stay inside it.
TEST(GeometryViews, SphereProjectsToItsClosedFormDisc) {
  TriangleMesh sphere = MakeOctasphere(5);
  for (auto& v : sphere.vertices) v += Eigen::Vector3f(0, 0, 5);  // camera at the origin looking along +z
  sphere.ComputeVertexNormals();
  const Camera camera = Camera::Pinhole(1, 200, 200, 200, 200, 100, 100);
  ImageRecord image;
  image.camera_id = 1;
  image.name = "view.png";
  const double radius_px = 200 / std::sqrt(24.0);
  const Image clay = RenderMeshView(sphere, camera, image, 400);
  ASSERT_EQ(clay.width, 200);
  double covered = 0;  // fraction of each pixel that is not white background
  int outside = 0;
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 200; ++x) {
      const double not_white = 1.0 - clay.at(x, y, 2);  // the clay's blue is at most 0.74: background is 1
      const double r = std::hypot(x + 0.5 - 100, y + 0.5 - 100);
      if (not_white > 1e-6) {
        covered += 1;
        if (r > radius_px + 1.5) ++outside;
      }
    }
  }
  EXPECT_EQ(outside, 0);
  // Pixels touched by the disc: its area plus about half its perimeter in partly covered edge pixels.
  EXPECT_NEAR(covered, M_PI * radius_px * radius_px + M_PI * radius_px, 0.03 * M_PI * radius_px * radius_px);
  // Scaled down to 100 px: half the size.
  EXPECT_EQ(RenderMeshView(sphere, camera, image, 100).width, 100);

  // The vertices as dots: inside the disc, and dense enough to cover most of it.
  const Image dots = RenderPointsView(sphere, camera, image, 200);
  int dots_inside = 0, dots_outside = 0;
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 200; ++x) {
      if (dots.at(x, y, 0) < 1.0f) {
        (std::hypot(x + 0.5 - 100, y + 0.5 - 100) <= radius_px + 1.5 ? dots_inside : dots_outside) += 1;
      }
    }
  }
  EXPECT_EQ(dots_outside, 0);
  EXPECT_GT(dots_inside, 0.8 * M_PI * radius_px * radius_px);
}

TEST(GeometryViews, SpreadViewsPicksEvenlyInNameOrder) {
  Reconstruction model;
  for (int i = 0; i < 10; ++i) {
    ImageRecord im;
    im.image_id = 10 - i;  // ids in reverse name order
    im.name = "p" + std::to_string(i) + ".jpg";
    model.images[im.image_id] = im;
  }
  std::vector<std::string> names;
  for (const ImageRecord* im : SpreadViews(model, 4)) names.push_back(im->name);
  EXPECT_EQ(names, std::vector<std::string>({"p1.jpg", "p3.jpg", "p6.jpg", "p8.jpg"}));
  EXPECT_EQ(SpreadViews(model, 20).size(), 10u);
}

}  // namespace
}  // namespace relight
