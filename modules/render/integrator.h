// Exitant radiance at a surface point: the rendering equation restricted to
// direct light with visibility (seed eq. 1, Haber et al. 2009),
//
//   L_o(x, w_o) = ∫ f(x, w_i, w_o) cos θ_i V(x, w_i) L_env(w_i) dw_i  + delta lights
//               [ + one bounce: ∫ f cos L_direct(hit(x, w_i), -w_i) dw_i ],
//
// estimated by stratified Monte Carlo that combines environment importance
// sampling (EnvMap::Sample) and BRDF importance sampling (BrdfLobe::Sample on a
// lobe chosen by its coefficient) with multiple importance sampling, power
// heuristic (Veach & Guibas, SIGGRAPH 1995; Veach's thesis §9.2). Each strategy's
// samples are stratified (jittered grid for square counts, Latin hypercube
// otherwise). Delta lights (directional, point) are added with a shadow ray.
// Shading uses the local frame of sphere/frame.h around the shading normal.
// Surfaces are two-sided (normals are turned towards the viewer); where an
// interpolated normal tips away from the viewer (near silhouettes) it is bent
// until the viewer is 0.01 above its horizon; directions below the geometric
// surface are treated as blocked.
#pragma once

#include <Eigen/Core>

#include "render/lighting.h"
#include "render/render_options.h"
#include "render/rng.h"
#include "render/scene.h"

namespace relight {

// Radiance leaving `point` towards `dir_out_world` (unit, pointing away from
// the surface), one Monte Carlo estimate with the sample counts of `options`
// (light_samples + brdf_samples, plus the bounce when options.interreflection).
Eigen::Vector3d OutgoingRadiance(const Scene& scene, const Lighting& lighting, const SurfacePoint& point,
                                 const Eigen::Vector3d& dir_out_world, const RenderOptions& options, Pcg32* rng);

// The RGB BRDF value (1/sr, no cosine) of a shading record for local directions.
Eigen::Vector3d EvalPointBrdf(const Scene& scene, const SurfacePoint& point, const Eigen::Vector3d& wi_local,
                              const Eigen::Vector3d& wo_local);

}  // namespace relight
