// Ray casting against triangle meshes with Embree 3. Queries are const and
// thread-safe; streams of rays use Embree's stream API for throughput.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <vector>

#include "geometry/mesh.h"

namespace relight {

struct Ray {
  Eigen::Vector3f origin;
  Eigen::Vector3f dir;  // need not be unit; t is in units of |dir|
  float t_near = 0.0f;
  float t_far = std::numeric_limits<float>::infinity();
};

struct RayHit {
  bool hit = false;
  float t = 0.0f;
  uint32_t geom_id = 0;          // index of the mesh in the RayCaster's list
  uint32_t prim_id = 0;          // face index in that mesh
  float u = 0.0f, v = 0.0f;      // barycentrics: p = (1-u-v) v0 + u v1 + v v2
  Eigen::Vector3f point = Eigen::Vector3f::Zero();   // world hit point
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // unit geometric normal of the face
};

class RayCaster {
 public:
  // The meshes must outlive the RayCaster. Mesh i has geom_id i.
  explicit RayCaster(const std::vector<const TriangleMesh*>& meshes);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  RayHit Intersect(const Ray& ray) const;
  bool Occluded(const Ray& ray) const;
  // Many rays at once (Embree stream API, chunks on all threads); `coherent` when neighbouring rays are similar.
  void IntersectStream(const std::vector<Ray>& rays, bool coherent, std::vector<RayHit>* hits) const;
  void OccludedStream(const Ray* rays, size_t count, bool coherent, uint8_t* occluded) const;

  // Vertex-normal interpolation at a hit (falls back to the face normal).
  Eigen::Vector3f ShadingNormal(const RayHit& hit) const;
  // Interpolates a per-vertex property of the hit mesh at the hit.
  float InterpolateProperty(const RayHit& hit, const std::vector<float>& values) const;
  const TriangleMesh& mesh(uint32_t geom_id) const { return *meshes_[geom_id]; }
  // Diagonal of the scene's bounding box; a scale for ray offsets.
  float SceneDiagonal() const { return diagonal_; }
  // A safe ray offset for this scene (1e-5 of the diagonal).
  float Epsilon() const { return 1e-5f * diagonal_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<const TriangleMesh*> meshes_;
  float diagonal_ = 1.0f;
};

}  // namespace relight
