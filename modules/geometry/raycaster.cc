#include "geometry/raycaster.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/log.h"

namespace relight {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

namespace {
void EmbreeError(void*, RTCError code, const char* message) {
  RLOG_ERROR("embree error {}: {}", static_cast<int>(code), message ? message : "");
}

void FillRay(const Ray& in, RTCRay* out) {
  out->org_x = in.origin.x();
  out->org_y = in.origin.y();
  out->org_z = in.origin.z();
  out->dir_x = in.dir.x();
  out->dir_y = in.dir.y();
  out->dir_z = in.dir.z();
  out->tnear = in.t_near;
  out->tfar = in.t_far;
  out->time = 0.0f;
  out->mask = 0xFFFFFFFFu;
  out->id = 0;
  out->flags = 0;
}
}  // namespace

RayCaster::RayCaster(const std::vector<const TriangleMesh*>& meshes) : impl_(new Impl), meshes_(meshes) {
  impl_->device = rtcNewDevice("verbose=0");
  RELIGHT_CHECK(impl_->device != nullptr) << "rtcNewDevice failed: " << rtcGetDeviceError(nullptr);
  rtcSetDeviceErrorFunction(impl_->device, EmbreeError, nullptr);
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  Eigen::AlignedBox3f box;
  for (size_t g = 0; g < meshes.size(); ++g) {
    const TriangleMesh& m = *meshes[g];
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), std::max<size_t>(1, m.vertices.size())));
    for (size_t i = 0; i < m.vertices.size(); ++i) {
      std::memcpy(vb + 3 * i, m.vertices[i].data(), 3 * sizeof(float));
      box.extend(m.vertices[i]);
    }
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(unsigned), m.faces.size()));
    for (size_t i = 0; i < m.faces.size(); ++i) {
      for (int k = 0; k < 3; ++k) ib[3 * i + k] = static_cast<unsigned>(m.faces[i][k]);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl_->scene, geom, static_cast<unsigned>(g));
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  if (!box.isEmpty()) diagonal_ = std::max(1e-6f, box.diagonal().norm());
}

RayCaster::~RayCaster() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

RayHit RayCaster::Intersect(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  FillRay(ray, &rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);
  RayHit hit;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  hit.hit = true;
  hit.t = rh.ray.tfar;
  hit.geom_id = rh.hit.geomID;
  hit.prim_id = rh.hit.primID;
  hit.u = rh.hit.u;
  hit.v = rh.hit.v;
  hit.point = ray.origin + hit.t * ray.dir;
  hit.normal = meshes_[hit.geom_id]->FaceNormal(static_cast<int>(hit.prim_id));
  return hit;
}

bool RayCaster::Occluded(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r;
  FillRay(ray, &r);
  rtcOccluded1(impl_->scene, &context, &r);
  return r.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

void RayCaster::IntersectStream(const std::vector<Ray>& rays, bool coherent, std::vector<RayHit>* hits) const {
  hits->resize(rays.size());
  // Chunks of the rays traced on all threads, each as one Embree stream (a ray's hit does not depend on the others).
  // Isolated: a caller inside a parallel loop with per-thread scratch (visibility/bounce.cc) must not have its
  // thread take another of its own iterations while it waits here.
  constexpr size_t kChunk = 4096;
  tbb::this_task_arena::isolate([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), kChunk), [&](const tbb::blocked_range<size_t>& range) {
      thread_local std::vector<RTCRayHit> rh;
      const size_t first = range.begin(), n = range.size();
      rh.resize(n);
      for (size_t i = 0; i < n; ++i) {
        FillRay(rays[first + i], &rh[i].ray);
        rh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      }
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      context.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
      rtcIntersect1M(impl_->scene, &context, rh.data(), static_cast<unsigned>(n), sizeof(RTCRayHit));
      for (size_t i = 0; i < n; ++i) {
        RayHit& h = (*hits)[first + i];
        h = RayHit();
        if (rh[i].hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
        h.hit = true;
        h.t = rh[i].ray.tfar;
        h.geom_id = rh[i].hit.geomID;
        h.prim_id = rh[i].hit.primID;
        h.u = rh[i].hit.u;
        h.v = rh[i].hit.v;
        h.point = rays[first + i].origin + h.t * rays[first + i].dir;
        h.normal = meshes_[h.geom_id]->FaceNormal(static_cast<int>(h.prim_id));
      }
    });
  });
}

void RayCaster::OccludedStream(const Ray* rays, size_t count, bool coherent, uint8_t* occluded) const {
  constexpr size_t kChunk = 256;
  RTCRay buffer[kChunk];
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  for (size_t start = 0; start < count; start += kChunk) {
    const size_t n = std::min(kChunk, count - start);
    for (size_t i = 0; i < n; ++i) FillRay(rays[start + i], &buffer[i]);
    rtcOccluded1M(impl_->scene, &context, buffer, static_cast<unsigned>(n), sizeof(RTCRay));
    for (size_t i = 0; i < n; ++i) occluded[start + i] = buffer[i].tfar < 0.0f ? 1 : 0;
  }
}

Eigen::Vector3f RayCaster::ShadingNormal(const RayHit& hit) const {
  const TriangleMesh& m = *meshes_[hit.geom_id];
  if (m.normals.size() != m.vertices.size()) return hit.normal;
  const auto& f = m.faces[hit.prim_id];
  const Eigen::Vector3f n = (1 - hit.u - hit.v) * m.normals[f[0]] + hit.u * m.normals[f[1]] + hit.v * m.normals[f[2]];
  const float len = n.norm();
  return len > 0 ? Eigen::Vector3f(n / len) : hit.normal;
}

float RayCaster::InterpolateProperty(const RayHit& hit, const std::vector<float>& values) const {
  const auto& f = meshes_[hit.geom_id]->faces[hit.prim_id];
  return (1 - hit.u - hit.v) * values[f[0]] + hit.u * values[f[1]] + hit.v * values[f[2]];
}

}  // namespace relight
