// What the renderer draws: triangle meshes with per-vertex material weights
// over a ReflectanceModel (brdf/brdf.h), ray-cast with Embree.
//
// A surface point's BRDF is sum_m w_m sum_b c_mb rho_b (docs/FORMATS.md,
// "materials.json"). Since that is linear in the weights, the scene stores per
// vertex the effective RGB coefficient of every basis lobe, k_b = sum_m w_m c_mb,
// and interpolates those barycentrically inside triangles: the same BRDF as
// interpolating the weights. Surfaces are two-sided.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "geometry/mesh.h"
#include "geometry/raycaster.h"

namespace relight {

// What a surface is for; only kObject surfaces enter object masks.
enum class SurfaceRole { kObject, kOccluder };

// Most basis lobes a surface may have (fixed-size shading records, no allocation per ray).
inline constexpr int kMaxLobes = 16;

// Everything the integrator needs at a point on a surface.
struct SurfacePoint {
  int surface = -1;  // index in the Scene
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_geometric_world = Eigen::Vector3d::UnitZ();  // unit; face normal (vertex normal at a vertex)
  Eigen::Vector3d normal_shading_world = Eigen::Vector3d::UnitZ();    // unit; interpolated vertex normal
  int num_lobes = 0;
  std::array<Eigen::Vector3d, kMaxLobes> lobe_rgb;  // effective RGB coefficient of each basis lobe
};

// An immutable scene: surfaces plus their Embree acceleration structure.
class Scene {
 public:
  // One surface: a mesh whose per-vertex properties `w0 … w{M-1}` weight the
  // M materials of `reflectance`. A model with one material needs no properties
  // (weight 1). Missing vertex normals are computed.
  struct Surface {
    TriangleMesh mesh;
    ReflectanceModel reflectance;
    SurfaceRole role = SurfaceRole::kObject;
  };

  // Builds the scene; throws UserError (naming `where`, e.g. a file) when a
  // surface lacks weight properties, has more than kMaxLobes lobes or a bad mesh.
  explicit Scene(std::vector<Surface> surfaces, const std::string& where = "scene");
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  // Number of surfaces; surface i has Embree geometry id i.
  int num_surfaces() const { return static_cast<int>(surfaces_.size()); }
  // Surface i as built (normals filled in).
  const Surface& surface(int i) const { return surfaces_[i]; }
  // Embree ray casting against all surfaces (geometry id = surface index).
  const RayCaster& caster() const { return *caster_; }
  // Diagonal of the scene's bounding box (a scale for ray offsets).
  double diagonal() const { return caster_->SceneDiagonal(); }

  // The shading record of a ray hit.
  SurfacePoint PointFromHit(const RayHit& hit) const;
  // The shading record of a mesh vertex (vertex normal as both normals, the vertex's own coefficients).
  SurfacePoint PointAtVertex(int surface, int vertex) const;

 private:
  std::vector<Surface> surfaces_;
  std::vector<std::vector<float>> lobe_rgb_;  // per surface: vertex-major, num_lobes * 3 floats per vertex
  std::unique_ptr<RayCaster> caster_;
};

// The material weights of a surface's mesh (properties w0 … w{M-1}), one vector per vertex.
// Throws UserError naming `where` when a property is missing.
std::vector<std::vector<double>> VertexMaterialWeights(const TriangleMesh& mesh, int num_materials,
                                                       const std::string& where);

// A one-material, one-lobe Lambertian model of the given RGB albedo.
ReflectanceModel LambertianModel(const Eigen::Vector3d& albedo_rgb, const std::string& name = "lambertian");

}  // namespace relight
