#include "evaluate/shadow_contrast.h"

#include <cmath>

#include "core/error.h"
#include "image/color.h"
#include "relight/display.h"
#include "relight/views.h"

namespace relight {

SunRegions SunAndShadowRegions(const RayCaster& truth, const Camera& camera, const ImageRecord& pose,
                               const Eigen::Vector3d& sun_dir_world, const Image& region, int erosion_px,
                               double min_cos) {
  const std::vector<RayHit> hits = CastPixelCentres(truth, camera, pose);
  const int w = camera.width, h = camera.height;
  const Eigen::Vector3f sun = sun_dir_world.normalized().cast<float>();
  const bool use_region = !region.empty();
  if (use_region && (region.width != w || region.height != h))
    RELIGHT_USER_ERROR() << "the region mask is " << region.width << "x" << region.height << " but the camera is " << w
                         << "x" << h;
  // Which pixels to test towards the sun: hits in the region that face it.
  const Eigen::Vector3f centre = pose.ProjectionCenter().cast<float>();
  std::vector<Ray> rays;
  std::vector<size_t> ray_pixel;
  Image lit(w, h, 1), shadow(w, h, 1);
  for (size_t k = 0; k < hits.size(); ++k) {
    const RayHit& hit = hits[k];
    if (!hit.hit) continue;
    if (use_region && region.pixels[k * region.channels] < 0.5f) continue;
    Eigen::Vector3f n = truth.ShadingNormal(hit);
    // Orient towards the camera: the side the pixel sees.
    if (n.dot(centre - hit.point) < 0) n = -n;
    const float cos_sun = n.dot(sun);
    if (cos_sun <= 0) {
      shadow.pixels[k] = 1;  // attached shadow
      continue;
    }
    if (cos_sun < min_cos) continue;  // grazing light: neither
    Ray ray;
    ray.origin = hit.point + 4 * truth.Epsilon() * n;
    ray.dir = sun;
    ray.t_near = truth.Epsilon();
    rays.push_back(ray);
    ray_pixel.push_back(k);
  }
  std::vector<uint8_t> occluded(rays.size(), 0);
  if (!rays.empty()) truth.OccludedStream(rays.data(), rays.size(), /*coherent=*/true, occluded.data());
  for (size_t i = 0; i < rays.size(); ++i) (occluded[i] ? shadow : lit).pixels[ray_pixel[i]] = 1;
  return {ErodeMask(lit, erosion_px), ErodeMask(shadow, erosion_px)};
}

namespace {

double MeanLuminance(const Image& image, const Image& mask) {
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      if (mask.at(x, y) < 0.5f) continue;
      sum += Luminance(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2));
      ++n;
    }
  return n ? sum / n : 0;
}

}  // namespace

ShadowContrast MeasureShadowContrast(const Image& reference, const Image& estimate, const SunRegions& regions,
                                     const std::string& what) {
  for (const Image* image : {&reference, &estimate})
    if (image->width != regions.lit.width || image->height != regions.lit.height || image->channels < 3)
      RELIGHT_USER_ERROR() << what << ": the image is " << image->width << "x" << image->height << "x"
                           << image->channels << ", the regions " << regions.lit.width << "x" << regions.lit.height
                           << " (RGB expected)";
  ShadowContrast c;
  c.lit_pixels = CountMask(regions.lit);
  c.shadow_pixels = CountMask(regions.shadow);
  if (c.lit_pixels == 0 || c.shadow_pixels == 0)
    RELIGHT_USER_ERROR() << what << ": " << c.lit_pixels << " sunlit and " << c.shadow_pixels
                         << " shadowed pixels: the view shows no shadow edge to measure";
  const double ref_lit = MeanLuminance(reference, regions.lit), ref_shadow = MeanLuminance(reference, regions.shadow);
  const double est_lit = MeanLuminance(estimate, regions.lit), est_shadow = MeanLuminance(estimate, regions.shadow);
  if (!(ref_shadow > 0) || !(est_shadow > 0))
    RELIGHT_USER_ERROR() << what << ": the shadowed pixels are black (reference " << ref_shadow << ", estimate "
                         << est_shadow << "): the ratio is unbounded; measure under a light with sky as well as sun";
  c.reference_ratio = ref_lit / ref_shadow;
  c.estimate_ratio = est_lit / est_shadow;
  c.relative_error = c.estimate_ratio / c.reference_ratio - 1;
  return c;
}

}  // namespace relight
