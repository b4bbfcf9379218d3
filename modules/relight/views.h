// Cameras the relight stage renders from and what evaluate/report need to
// know about them: orbit cameras around the object, camera (de)serialisation
// for the render index, pixel-centre ray casting, and flat per-vertex colour
// images (albedo and material maps, no lighting).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/json.h"
#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "geometry/raycaster.h"
#include "geometry/reconstruction.h"
#include "image/image.h"

namespace relight {

// A named view: COLMAP intrinsics and pose (cam_from_world).
struct RenderCamera {
  std::string name;
  Camera camera;
  ImageRecord pose;
};

// Rotation cam_from_world of a camera at `center` looking at `target`, world +Z up in the image (-y).
Eigen::Matrix3d LookAtCamFromWorld(const Eigen::Vector3d& center, const Eigen::Vector3d& target);

// A square PINHOLE camera of `size` px and horizontal field of view `fov_deg` on an orbit around the
// sphere (`center`, `radius`): at `azimuth_deg` (from +X towards +Y) and `elevation_deg`, at the distance
// where the sphere spans `fill` of the image side, looking at the centre, +Z up.
RenderCamera OrbitCamera(const std::string& name, const Eigen::Vector3d& center, double radius, double azimuth_deg,
                         double elevation_deg, int size, double fov_deg, double fill);

// {"model", "width", "height", "params", "qvec" (w, x, y, z of cam_from_world), "tvec"}.
Json CameraToJson(const Camera& camera, const ImageRecord& pose);
// Inverse of CameraToJson; throws UserError naming `where` on missing fields.
RenderCamera CameraFromJson(const Json& j, const std::string& where);

// First hits of the rays through every pixel centre (row-major, width x height); hit.geom_id indexes the
// caster's meshes.
std::vector<RayHit> CastPixelCentres(const RayCaster& caster, const Camera& camera, const ImageRecord& pose);

// Flat image of per-vertex RGB values of mesh `geom_id`: each pixel whose centre ray first hits that mesh
// gets the barycentric interpolation of `vertex_rgb` at the hit; other pixels `background_rgb`. `mask`
// (optional) gets 1 on those pixels.
Image RenderVertexColors(const RayCaster& caster, uint32_t geom_id, const std::vector<Eigen::Vector3f>& vertex_rgb,
                         const Camera& camera, const ImageRecord& pose, const Eigen::Vector3f& background_rgb,
                         Image* mask = nullptr);

// Centre and radius (largest vertex distance from the bounding-box centre) of a mesh.
void MeshBoundingSphere(const TriangleMesh& mesh, Eigen::Vector3d* center, double* radius);

}  // namespace relight
