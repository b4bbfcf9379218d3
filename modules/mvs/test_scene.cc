#include "mvs/test_scene.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <map>

#include "core/error.h"
#include "core/fs.h"
#include "geometry/mesh_io.h"
#include "geometry/primitives.h"
#include "geometry/raycaster.h"
#include "mvs/mesh_metrics.h"

namespace relight::mvs_test {
namespace {

float Hash(int x, int y, int z) {
  uint32_t h = uint32_t(x) * 73856093u ^ uint32_t(y) * 19349663u ^ uint32_t(z) * 83492791u;
  h ^= h >> 16;
  h *= 0x7feb352dU;
  h ^= h >> 15;
  h *= 0x846ca68bU;
  h ^= h >> 16;
  return float(h >> 8) * (1.0f / 16777216.0f);
}

float ValueNoise(const Eigen::Vector3f& p) {
  const Eigen::Vector3f f(std::floor(p.x()), std::floor(p.y()), std::floor(p.z()));
  const Eigen::Vector3f t = p - f;
  const Eigen::Vector3f s = t.cwiseProduct(t).cwiseProduct(Eigen::Vector3f::Constant(3) - 2 * t);  // smoothstep
  const int x = int(f.x()), y = int(f.y()), z = int(f.z());
  float result = 0;
  for (int k = 0; k < 8; ++k) {
    const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
    const float w = (dx ? s.x() : 1 - s.x()) * (dy ? s.y() : 1 - s.y()) * (dz ? s.z() : 1 - s.z());
    result += w * Hash(x + dx, y + dy, z + dz);
  }
  return result;
}

Eigen::Vector3f Albedo(const Eigen::Vector3f& p) {
  const float a = 0.5f * ValueNoise(6.0f * p) + 0.3f * ValueNoise(13.0f * p + Eigen::Vector3f(3, 1, 7)) +
                  0.2f * ValueNoise(27.0f * p + Eigen::Vector3f(5, 9, 2));
  const float albedo = 0.08f + 0.9f * std::clamp((a - 0.5f) * 2.2f + 0.5f, 0.0f, 1.0f);
  const float tint = ValueNoise(3.0f * p + Eigen::Vector3f(11, 2, 5));
  return albedo * Eigen::Vector3f(1.0f, 0.85f + 0.15f * tint, 0.75f + 0.25f * (1 - tint));
}

}  // namespace

TriangleMesh MakeBumpySphere(int subdivisions) {
  const TriangleMesh sphere = MakeIcosphere(subdivisions);
  std::vector<Eigen::Vector3d> v;
  for (const auto& p : sphere.vertices) v.push_back(p.cast<double>());
  const std::vector<Eigen::Vector3i>& f = sphere.faces;
  TriangleMesh mesh;
  for (const auto& d : v) {
    const double r = 1.0 + 0.12 * std::sin(3 * d.x() + 1) * std::cos(2 * d.y()) + 0.08 * std::sin(5 * d.z() + 2 * d.x());
    mesh.vertices.push_back((r * d).cast<float>());
  }
  mesh.faces = f;
  // Outward orientation: positive signed volume.
  double volume = 0;
  for (const auto& tri : mesh.faces) {
    volume += mesh.vertices[tri[0]].cast<double>().dot(
        mesh.vertices[tri[1]].cast<double>().cross(mesh.vertices[tri[2]].cast<double>()));
  }
  if (volume < 0) {
    for (auto& tri : mesh.faces) std::swap(tri[1], tri[2]);
  }
  mesh.ComputeVertexNormals();
  return mesh;
}

TriangleMesh MakeSquare(double size, double z) {
  TriangleMesh mesh;
  const float h = float(size / 2), zf = float(z);
  mesh.vertices = {{-h, -h, zf}, {h, -h, zf}, {h, h, zf}, {-h, h, zf}};
  mesh.faces = {{0, 2, 1}, {0, 3, 2}};  // normal -z
  mesh.ComputeVertexNormals();
  return mesh;
}

std::vector<ImageRecord> LookAtCameras(const std::vector<Eigen::Vector3d>& centers, const Eigen::Vector3d& target) {
  std::vector<ImageRecord> images;
  for (size_t i = 0; i < centers.size(); ++i) {
    const Eigen::Vector3d z = (target - centers[i]).normalized();
    Eigen::Vector3d up(0, 0, 1);
    if (std::abs(z.dot(up)) > 0.99) up = Eigen::Vector3d(0, 1, 0);
    const Eigen::Vector3d x = z.cross(up).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d R;
    R.row(0) = x;
    R.row(1) = y;
    R.row(2) = z;
    ImageRecord image;
    image.image_id = static_cast<uint32_t>(i + 1);
    image.camera_id = 1;
    char name[32];
    std::snprintf(name, sizeof(name), "view_%02zu.png", i);
    image.name = name;
    image.SetPose(R, centers[i]);
    images.push_back(image);
  }
  return images;
}

std::vector<Eigen::Vector3d> TwoRingCenters(int per_ring, double distance) {
  std::vector<Eigen::Vector3d> centers;
  for (int ring = 0; ring < 2; ++ring) {
    const double elevation = (ring == 0 ? 35.0 : -20.0) * M_PI / 180.0;
    for (int i = 0; i < per_ring; ++i) {
      const double azimuth = 2 * M_PI * (i + 0.5 * ring) / per_ring;
      centers.emplace_back(distance * std::cos(elevation) * std::cos(azimuth),
                           distance * std::cos(elevation) * std::sin(azimuth), distance * std::sin(elevation));
    }
  }
  return centers;
}

TestScene RenderScene(const TriangleMesh& mesh, const Camera& camera, const std::vector<ImageRecord>& poses,
                      int num_points, uint64_t seed) {
  TestScene scene;
  scene.mesh = mesh;
  if (scene.mesh.normals.size() != scene.mesh.vertices.size()) scene.mesh.ComputeVertexNormals();
  const Eigen::AlignedBox3f box = scene.mesh.BoundingBox();
  scene.bbox_diagonal = (box.max() - box.min()).norm();
  scene.model.cameras[camera.camera_id] = camera;
  const RayCaster caster({&scene.mesh});
  const Eigen::Matrix3d K_inv = camera.K().inverse();
  const Eigen::Vector3f light = Eigen::Vector3f(0.3f, 0.5f, 0.8f).normalized();
  for (const ImageRecord& pose : poses) {
    ImageRecord image = pose;
    image.camera_id = camera.camera_id;
    scene.model.images[image.image_id] = image;
    const Eigen::Matrix3f world_from_cam = image.CamFromWorldRotation().transpose().cast<float>();
    const Eigen::Vector3f center = image.ProjectionCenter().cast<float>();
    Image rgb(camera.width, camera.height, 3, 0.0f);
    Image depth(camera.width, camera.height, 1, 0.0f);
    tbb::parallel_for(0, camera.height, [&](int row) {
      for (int col = 0; col < camera.width; ++col) {
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        for (int s = 0; s < 5; ++s) {  // 4 subpixel samples for colour, then the centre for depth
          const double u = s < 4 ? col + 0.25 + 0.5 * (s % 2) : col + 0.5;
          const double v = s < 4 ? row + 0.25 + 0.5 * (s / 2) : row + 0.5;
          Ray ray;
          ray.origin = center;
          ray.dir = world_from_cam * (K_inv * Eigen::Vector3d(u, v, 1.0)).cast<float>();  // camera z = t
          const RayHit hit = caster.Intersect(ray);
          if (!hit.hit) continue;
          if (s == 4) {
            depth.at(col, row) = hit.t;
            continue;
          }
          Eigen::Vector3f n = caster.ShadingNormal(hit);
          const float shade = 0.35f + 0.65f * std::max(0.0f, n.dot(light));
          sum += shade * Albedo(hit.point);
        }
        for (int c = 0; c < 3; ++c) rgb.at(col, row, c) = std::pow(std::clamp(0.25f * sum[c], 0.0f, 1.0f), 1 / 2.2f);
      }
    });
    scene.images.push_back(std::move(rgb));
    scene.depths.push_back(std::move(depth));
  }
  // Sparse points: surface samples with the views that see them.
  const std::vector<Eigen::Vector3f> samples = SampleSurface(scene.mesh, num_points, seed);
  uint64_t next_id = 1;
  for (const auto& p : samples) {
    Point3D point;
    point.point3d_id = next_id;
    point.xyz = p.cast<double>();
    std::vector<std::pair<uint32_t, Eigen::Vector2d>> observations;
    for (const auto& [id, image] : scene.model.images) {
      Eigen::Vector2d pixel;
      if (!scene.model.Project(image, point.xyz, &pixel)) continue;
      if (pixel.x() < 0 || pixel.y() < 0 || pixel.x() >= camera.width || pixel.y() >= camera.height) continue;
      Ray ray;
      ray.origin = image.ProjectionCenter().cast<float>();
      ray.dir = p - ray.origin;
      ray.t_far = 1.0f - 1e-3f;
      if (caster.Occluded(ray)) continue;
      observations.emplace_back(id, pixel);
    }
    if (observations.size() < 2) continue;
    for (const auto& [id, pixel] : observations) {
      ImageRecord& image = scene.model.images[id];
      Point2D p2;
      p2.xy = pixel;
      p2.point3d_id = next_id;
      point.track.emplace_back(id, static_cast<uint32_t>(image.points2d.size()));
      image.points2d.push_back(p2);
    }
    scene.model.points3d[next_id++] = point;
  }
  return scene;
}

void WriteSfmWorkspace(const TestScene& scene, const std::string& sfm_dir) {
  EnsureDir(sfm_dir + "/dense/images");
  EnsureDir(sfm_dir + "/dense/sparse");
  size_t k = 0;
  for (const auto& [id, image] : scene.model.images) {
    WriteImage(sfm_dir + "/dense/images/" + image.name, scene.images[k++]);
  }
  scene.model.WriteBinary(sfm_dir + "/dense/sparse");
}

void WriteGroundTruth(const TestScene& scene, const std::string& dir) {
  EnsureDir(dir + "/depth");
  scene.model.WriteText(dir);
  WriteMeshPly(dir + "/mesh.ply", scene.mesh);
  size_t k = 0;
  for (const auto& [id, image] : scene.model.images) {
    const std::string stem = image.name.substr(0, image.name.rfind('.'));
    WriteImage(dir + "/depth/" + stem + ".exr", scene.depths[k++], {PixelType::kFloat});
  }
}

Image ToGray(const Image& rgb) {
  Image gray(rgb.width, rgb.height, 1);
  for (size_t i = 0; i < gray.pixels.size(); ++i) {
    const float* p = &rgb.pixels[i * rgb.channels];
    gray.pixels[i] = 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2];
  }
  return gray;
}

std::vector<ImageRecord> CamerasLookingAlongZ(const std::vector<Eigen::Vector3d>& centers, const std::string& prefix) {
  std::vector<ImageRecord> poses;
  for (size_t i = 0; i < centers.size(); ++i) {
    ImageRecord image;
    image.image_id = static_cast<uint32_t>(i + 1);
    image.camera_id = 1;
    image.name = prefix + std::to_string(i) + ".png";
    image.SetPose(Eigen::Matrix3d::Identity(), centers[i]);
    poses.push_back(image);
  }
  return poses;
}

}  // namespace relight::mvs_test
