// Per reference image: which source views to match against and which depths
// to search, from the sparse SfM model (COLMAP's `__auto__` selection in
// patch-match.cfg: most shared 3D points seen under a sufficient
// triangulation angle; depth range from the percentiles of the sparse
// points' depths, Schönberger et al. 2016 §5). Unlike COLMAP, each shared
// point counts (1 + cos α) / 2 for its triangulation angle α: 1 for close
// views, 1/2 at 90°, 0.1 at 143°. A flat textured ground or facade is matched
// by SIFT from the opposite side of a ring of photos, so a view across the
// ring can share more points than a neighbour while it sees nothing of the
// object's near side (COLMAP then relies on per-pixel view selection among 20
// sources; we match against a few). A hard angle limit would not do: on a
// convex object the views beyond 90° are the ones that see the reference's
// silhouette regions, and they should still fill the remaining slots.
//
// A model without 3D points (cameras given as ground truth) falls back to the
// poses alone: the point closest to all optical axes is taken as the scene
// centre, sources are the views that see it under a triangulation angle
// nearest to `kPreferredAngleDeg`, and the depth range is where the
// reference's viewing frustum overlaps the frusta of three quarters of its
// sources (at least `num_best_views` of them), within a factor of three
// either side of the centre's depth: only there can enough sources see a
// surface to match it. A view that shares points with too few sources (fewer
// than max(num_best_views, filter_min_num_consistent) + 1: a photo under a
// light of its own may match only one neighbour) gets the rest chosen the
// same way from the poses.
#pragma once

#include <string>
#include <vector>

#include "geometry/reconstruction.h"
#include "mvs/mvs_options.h"
#include "mvs/stereo_view.h"

namespace relight {

// The plan for one reference image.
struct ViewSelection {
  int ref = -1;                       // index into the views
  std::vector<int> sources;           // indices into the views, best first
  std::vector<int> shared_points;     // usable shared sparse points per source
  std::vector<double> shared_score;   // their weighted count, (1 + cos angle) / 2 each (the ranking)
  std::vector<double> median_angle_deg;  // median triangulation angle of those points per source
  double depth_min = 0;               // search range of camera z (0 when unknown)
  double depth_max = 0;
  int num_points = 0;                 // sparse points the depth range came from
  bool from_poses = false;            // chosen by the pose-only fallback (no sparse points)
  int num_pose_sources = 0;           // sources added from the poses because too few share points (last ones)
  std::string skip_reason;            // non-empty: the image cannot be a reference (no sources / no depth range)
};

// Depth range (camera z) of the points that `ref` sees (inside its image) and at least `min_views` of `sources`
// see too (in front, inside their images), from the rays through a grid of points over ref's image; each ray's
// intervals inside the sources' frusta are exact (five half-spaces each). False when no such point exists.
bool FrustumOverlapDepthRange(const StereoView& ref, const std::vector<const StereoView*>& sources, int min_views,
                              double* depth_min, double* depth_max);

// One plan per view (same order). `views` must come from `model` (image_id set).
std::vector<ViewSelection> SelectViews(const Reconstruction& model, const std::vector<StereoView>& views,
                                       const MvsOptions& options);

}  // namespace relight
