// Shadow contrast of a relit view under a sun (docs/METRICS.md, "Shadow contrast"): how much darker
// the surface the sun does not reach is than the surface it lights, in the reference and in the
// relit estimate. A reflectance that absorbed the photos' shading (shadows baked into the albedo)
// or a light without a sharp sun gives a flatter relit view: a lower ratio than the reference's.
//
// The regions come from the true geometry only (ray casts against the truth's meshes), so both
// images are measured over the same pixels:
//   lit:    the first hit faces the sun (shading normal . sun >= min_cos) and a ray towards the
//           sun leaves the scene unblocked;
//   shadow: the first hit faces away from the sun, or a ray towards it is blocked;
// each eroded by `erosion_px` so a pixel near a shadow edge (where a reconstructed mesh's shadow
// may sit a pixel away) counts in neither.
//   ratio = mean luminance over lit pixels / mean luminance over shadow pixels.
// A scale of the estimate cancels in the ratio (inverse rendering recovers light up to a scale).
#pragma once

#include <Eigen/Core>

#include "geometry/raycaster.h"
#include "geometry/reconstruction.h"
#include "image/image.h"

namespace relight {

struct SunRegions {
  Image lit;     // 1 channel, 1 on lit pixels
  Image shadow;  // 1 channel, 1 on shadow pixels
};

// Regions of the view (`camera`, `pose`) of the caster's scene under a sun towards `sun_dir_world`
// (any length). Pixels whose centre ray misses the scene, or hits it where `region` (1 channel, same
// size; empty: everywhere) is below 0.5, are in neither region.
SunRegions SunAndShadowRegions(const RayCaster& truth, const Camera& camera, const ImageRecord& pose,
                               const Eigen::Vector3d& sun_dir_world, const Image& region, int erosion_px = 2,
                               double min_cos = 0.2);

struct ShadowContrast {
  size_t lit_pixels = 0, shadow_pixels = 0;
  double reference_ratio = 0;  // lit / shadow mean luminance of the reference
  double estimate_ratio = 0;   // the same for the estimate
  // estimate_ratio / reference_ratio - 1: negative when the estimate's shadows are too light.
  double relative_error = 0;
};

// Both images RGB of the regions' size. Throws UserError naming `what` when a region is empty or a
// mean shadow luminance is not positive (a black shadow has no finite ratio: add sky light).
ShadowContrast MeasureShadowContrast(const Image& reference, const Image& estimate, const SunRegions& regions,
                                     const std::string& what);

}  // namespace relight
