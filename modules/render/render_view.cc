#include "render/render_view.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "core/error.h"
#include "core/timer.h"
#include "render/integrator.h"
#include "render/rng.h"

namespace relight {

int64_t NumTiles(const Camera& camera, const RenderOptions& options) {
  const int64_t tiles_x = (camera.width + options.tile_size - 1) / options.tile_size;
  const int64_t tiles_y = (camera.height + options.tile_size - 1) / options.tile_size;
  return tiles_x * tiles_y;
}

RenderedView RenderView(const Scene& scene, const Lighting& lighting, const Camera& camera, const ImageRecord& pose,
                        const RenderOptions& options, uint64_t view_index, Progress* progress) {
  options.Check();
  camera.Check("RenderView camera " + std::to_string(camera.camera_id));
  Timer timer;
  const int width = camera.width, height = camera.height;
  RenderedView out;
  out.radiance = Image(width, height, 3);
  out.mask = Image(width, height, 1);
  out.coverage = Image(width, height, 1);
  out.depth = Image(width, height, 1);
  out.surface = Image(width, height, 1, -1.0f);
  const Eigen::Matrix3d world_from_cam = pose.CamFromWorldRotation().transpose();
  const Eigen::Vector3f center = pose.ProjectionCenter().cast<float>();
  const int tile = options.tile_size;
  const int tiles_x = (width + tile - 1) / tile;
  const int64_t num_tiles = NumTiles(camera, options);
  const int k = options.pixel_samples_per_axis;
  const uint64_t view_seed = MixSeed(options.seed, view_index);

  auto trace = [&](double px, double py, Eigen::Vector3d* dir_cam, RayHit* hit) {
    *dir_cam = camera.RayFromImage({px, py}).normalized();
    Ray ray;
    ray.origin = center;
    ray.dir = (world_from_cam * *dir_cam).cast<float>();
    *hit = scene.caster().Intersect(ray);
    return (world_from_cam * *dir_cam).eval();
  };

  tbb::parallel_for(tbb::blocked_range<int64_t>(0, num_tiles, 1), [&](const tbb::blocked_range<int64_t>& range) {
    for (int64_t t = range.begin(); t != range.end(); ++t) {
      const int x0 = int(t % tiles_x) * tile, y0 = int(t / tiles_x) * tile;
      const int x1 = std::min(width, x0 + tile), y1 = std::min(height, y0 + tile);
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
          Pcg32 rng(view_seed, uint64_t(y) * width + x);
          Eigen::Vector3d sum = Eigen::Vector3d::Zero();
          int object_rays = 0;
          for (int sy = 0; sy < k; ++sy) {
            for (int sx = 0; sx < k; ++sx) {
              const double px = x + (sx + rng.Uniform()) / k, py = y + (sy + rng.Uniform()) / k;
              Eigen::Vector3d dir_cam;
              RayHit hit;
              const Eigen::Vector3d dir_world = trace(px, py, &dir_cam, &hit);
              if (hit.hit) {
                const SurfacePoint point = scene.PointFromHit(hit);
                if (scene.surface(point.surface).role == SurfaceRole::kObject) ++object_rays;
                sum += OutgoingRadiance(scene, lighting, point, -dir_world, options, &rng);
              } else if (options.background) {
                sum += lighting.Background(dir_world);
              }
            }
          }
          sum /= double(k * k);
          for (int c = 0; c < 3; ++c) out.radiance.at(x, y, c) = float(sum[c]);
          out.coverage.at(x, y) = float(object_rays) / float(k * k);
          Eigen::Vector3d dir_cam;
          RayHit hit;
          trace(x + 0.5, y + 0.5, &dir_cam, &hit);
          if (hit.hit) {
            out.depth.at(x, y) = float(hit.t * dir_cam.z());
            out.surface.at(x, y) = float(hit.geom_id);
            out.mask.at(x, y) = scene.surface(int(hit.geom_id)).role == SurfaceRole::kObject ? 1.0f : 0.0f;
          }
        }
      }
      if (progress != nullptr) progress->Advance();
    }
  });
  out.seconds = timer.Seconds();
  return out;
}

RadianceEstimate PointRadiance(const Scene& scene, const Lighting& lighting, const SurfacePoint& point,
                               const Eigen::Vector3d& dir_out_world, const RenderOptions& options, int num_estimates,
                               uint64_t stream) {
  options.Check();
  RELIGHT_CHECK_GT(num_estimates, 0);
  RadianceEstimate result;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), m2 = Eigen::Vector3d::Zero();
  const uint64_t seed = MixSeed(options.seed, stream);
  for (int i = 0; i < num_estimates; ++i) {
    Pcg32 rng(seed, uint64_t(i));
    const Eigen::Vector3d x = OutgoingRadiance(scene, lighting, point, dir_out_world, options, &rng);
    const Eigen::Vector3d delta = x - mean;
    mean += delta / double(i + 1);
    m2 += delta.cwiseProduct(x - mean);
  }
  result.mean = mean;
  result.num_estimates = num_estimates;
  if (num_estimates > 1) result.std_error = (m2 / double(num_estimates - 1) / double(num_estimates)).cwiseSqrt();
  return result;
}

RadianceEstimate VertexRadiance(const Scene& scene, const Lighting& lighting, int surface, int vertex,
                                const Eigen::Vector3d& dir_out_world, const RenderOptions& options, int num_estimates) {
  const SurfacePoint point = scene.PointAtVertex(surface, vertex);
  return PointRadiance(scene, lighting, point, dir_out_world, options, num_estimates,
                       MixSeed(uint64_t(surface) + 0x5EED, uint64_t(vertex)));
}

}  // namespace relight
