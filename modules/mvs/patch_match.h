// PatchMatch multi-view stereo for one reference image.
//
// Follows Schönberger et al., "Pixelwise View Selection for Unstructured
// Multi-View Stereo" (ECCV 2016; COLMAP) for the plane-induced homography
// (eq. 1), the bilateral NCC cost (eq. 2, see ncc_cost.h) and the geometric
// consistency term (§4.3: cost + λ·min(forward-backward reprojection error,
// ψ_max)), and Galliani et al., "Massively Parallel Multiview Stereopsis by
// Surface Normal Diffusion" (ICCV 2015; Gipuma) and Xu & Tao, "Multi-Scale
// Geometric Consistency Guided Multi-View Stereo" (CVPR 2019; ACMH/ACMM) for
// the schedule: red-black (checkerboard) updates in which every pixel of one
// colour is updated in parallel from the other colour; candidates from the
// eight adaptive-checkerboard regions (the lowest-cost neighbour of each of
// four near V-shaped and four far strip regions, ACMH §3.1); random
// refinement by perturbed and random depths and normals with a range halved
// per iteration; multi-view aggregation as the mean cost of the k best source
// views (Gipuma §3.2). Plane hypotheses are propagated by intersecting the
// neighbour's plane with this pixel's ray.
//
// Written by hand: no packaged library does multi-view PatchMatch on the CPU
// (COLMAP's runs only on CUDA; OpenCV's stereo is rectified two-view).
#pragma once

#include <string>
#include <vector>

#include "mvs/mvs_options.h"
#include "mvs/stereo_view.h"

namespace relight {

// Which implementation of the NCC cost the sweeps call (see ncc_cost.h).
enum class CostKernel {
  kVectorized,  // RefWindow once per pixel + vectorised sample loop (production)
  kPlain,       // NccCostPlain per hypothesis and view (benchmark baseline)
};

// Everything PatchMatch needs for one reference image.
struct PatchMatchProblem {
  const StereoView* ref = nullptr;                // with `gray` loaded
  std::vector<const StereoView*> sources;         // with `gray` loaded
  // Geometric pass: the photometric maps of the sources (same order; nullptr where missing). Empty otherwise.
  std::vector<const DepthNormalMap*> source_maps;
  double depth_min = 0;                           // search range of camera z
  double depth_max = 0;
  uint64_t image_seed = 0;                        // distinguishes reference images in the random streams
};

// What one run did.
struct PatchMatchStats {
  int iterations = 0;
  double seconds = 0;
  double mean_cost = 0;          // mean aggregated cost over textured pixels at the end
  double textured_fraction = 0;  // pixels whose window has enough texture to match
};

// Runs `iterations` PatchMatch iterations. With `init` (same size as the reference view) its valid pixels
// start from their plane, the others from random planes; `iteration_offset` continues the perturbation
// schedule of an earlier pass. `geometric` adds the reprojection term against `problem.source_maps`.
DepthNormalMap RunPatchMatch(const MvsOptions& options, const PatchMatchProblem& problem, bool geometric,
                             int iterations, const DepthNormalMap* init = nullptr, int iteration_offset = 0,
                             CostKernel kernel = CostKernel::kVectorized, PatchMatchStats* stats = nullptr);

// What filtering removed.
struct FilterStats {
  double valid_before = 0;        // fraction of pixels with a depth before filtering
  double valid_after = 0;         // ... after
  size_t removed_support = 0;     // too few consistent source views
  size_t removed_segments = 0;    // in connected segments smaller than filter_min_segment_px
};

// Keeps pixels that at least `filter_min_num_consistent` source views support (NCC ≥ filter_min_ncc,
// triangulation angle ≥ filter_min_triangulation_angle_deg, and with `geometric` a reprojection error
// ≤ filter_geom_max_error_px), then removes small connected segments (COLMAP's filter; ACMM's speckles).
FilterStats FilterDepthMap(const MvsOptions& options, const PatchMatchProblem& problem, bool geometric,
                           DepthNormalMap* map);

}  // namespace relight
