#include "relight/views.h"

#include <cmath>

#include "core/error.h"

namespace relight {

Eigen::Matrix3d LookAtCamFromWorld(const Eigen::Vector3d& center, const Eigen::Vector3d& target) {
  const Eigen::Vector3d forward = (target - center).normalized();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (right.norm() < 1e-9) right = Eigen::Vector3d::UnitX();  // looking straight up or down
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.row(0) = right;
  r.row(1) = down;
  r.row(2) = forward;
  return r;
}

RenderCamera OrbitCamera(const std::string& name, const Eigen::Vector3d& center, double radius, double azimuth_deg,
                         double elevation_deg, int size, double fov_deg, double fill) {
  RELIGHT_CHECK(size > 0 && radius > 0 && fov_deg > 0 && fill > 0);
  const double half_fov = 0.5 * fov_deg * M_PI / 180;
  // The sphere's silhouette spans angle asin(r / d) from the axis; it should cover `fill` of the half image.
  const double half_span = std::atan(fill * std::tan(half_fov));
  const double distance = radius / std::sin(half_span);
  const double az = azimuth_deg * M_PI / 180, el = elevation_deg * M_PI / 180;
  const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  const Eigen::Vector3d position = center + distance * dir;
  RenderCamera view;
  view.name = name;
  const double focal = 0.5 * size / std::tan(half_fov);
  view.camera = Camera::Pinhole(1, size, size, focal, focal, 0.5 * size, 0.5 * size);
  view.pose.name = name;
  view.pose.camera_id = 1;
  view.pose.SetPose(LookAtCamFromWorld(position, center), position);
  return view;
}

Json CameraToJson(const Camera& camera, const ImageRecord& pose) {
  const Eigen::Quaterniond& q = pose.cam_from_world_rotation;
  const Eigen::Vector3d& t = pose.cam_from_world_translation;
  return Json{{"model", camera.model},
              {"width", camera.width},
              {"height", camera.height},
              {"params", camera.params},
              {"qvec", {q.w(), q.x(), q.y(), q.z()}},
              {"tvec", {t.x(), t.y(), t.z()}}};
}

RenderCamera CameraFromJson(const Json& j, const std::string& where) {
  RenderCamera view;
  try {
    view.camera.model = j.at("model").get<std::string>();
    view.camera.width = j.at("width").get<int>();
    view.camera.height = j.at("height").get<int>();
    view.camera.params = j.at("params").get<std::vector<double>>();
    const auto q = j.at("qvec").get<std::vector<double>>();
    const auto t = j.at("tvec").get<std::vector<double>>();
    if (q.size() != 4 || t.size() != 3) throw std::runtime_error("qvec needs 4 and tvec 3 numbers");
    view.pose.cam_from_world_rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
    view.pose.cam_from_world_translation = Eigen::Vector3d(t[0], t[1], t[2]);
  } catch (const std::exception& e) {
    RELIGHT_USER_ERROR() << where << ": bad camera entry (" << e.what() << "); rerun the stage that wrote it";
  }
  view.camera.Check(where);
  return view;
}

std::vector<RayHit> CastPixelCentres(const RayCaster& caster, const Camera& camera, const ImageRecord& pose) {
  const Eigen::Matrix3d world_from_cam = pose.CamFromWorldRotation().transpose();
  const Eigen::Vector3f origin = pose.ProjectionCenter().cast<float>();
  std::vector<Ray> rays(size_t(camera.width) * camera.height);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      Ray& ray = rays[size_t(y) * camera.width + x];
      ray.origin = origin;
      ray.dir = (world_from_cam * camera.RayFromImage(Eigen::Vector2d(x + 0.5, y + 0.5))).cast<float>();
    }
  std::vector<RayHit> hits;
  caster.IntersectStream(rays, true, &hits);
  return hits;
}

Image RenderVertexColors(const RayCaster& caster, uint32_t geom_id, const std::vector<Eigen::Vector3f>& vertex_rgb,
                         const Camera& camera, const ImageRecord& pose, const Eigen::Vector3f& background_rgb,
                         Image* mask) {
  const TriangleMesh& mesh = caster.mesh(geom_id);
  RELIGHT_CHECK_EQ(vertex_rgb.size(), mesh.num_vertices());
  const std::vector<RayHit> hits = CastPixelCentres(caster, camera, pose);
  Image out(camera.width, camera.height, 3);
  if (mask != nullptr) *mask = Image(camera.width, camera.height, 1);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const RayHit& hit = hits[size_t(y) * camera.width + x];
      Eigen::Vector3f rgb = background_rgb;
      if (hit.hit && hit.geom_id == geom_id) {
        const Eigen::Vector3i& f = mesh.faces[hit.prim_id];
        rgb = (1 - hit.u - hit.v) * vertex_rgb[f[0]] + hit.u * vertex_rgb[f[1]] + hit.v * vertex_rgb[f[2]];
        if (mask != nullptr) mask->at(x, y) = 1;
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = rgb[c];
    }
  return out;
}

void MeshBoundingSphere(const TriangleMesh& mesh, Eigen::Vector3d* center, double* radius) {
  RELIGHT_CHECK(!mesh.vertices.empty());
  const Eigen::AlignedBox3f box = mesh.BoundingBox();
  *center = box.center().cast<double>();
  double r = 0;
  for (const auto& v : mesh.vertices) r = std::max(r, (v.cast<double>() - *center).norm());
  *radius = std::max(r, 1e-9);
}

}  // namespace relight
