// Scores an `mvs` output folder against a ground-truth folder
// (docs/FORMATS.md, "Ground truth folder") with the metrics of issue 9:
//
//  - per view, depth completeness: the fraction of the object's pixels whose
//    depth is within `depth_tolerance` of a depth range (object pixels:
//    ground_truth/masks/<stem>.png when present, else every pixel with a true
//    depth), with two ranges: the view's true depth range over the object
//    (the stricter figure), and over the whole scene, i.e. every pixel with a
//    true depth, ground and blockers included (issue 9's wording, "1% of the
//    scene depth range"); plus where the rest goes (no depth, wrong depth,
//    near silhouettes and depth edges or inside); and the same scene-range
//    figure over every visible pixel (every pixel with a true depth: object,
//    ground and blockers), issue 9's "visible pixels" read literally;
//  - fused points: accuracy (fraction within `accuracy_threshold` of the true
//    surfaces) and completeness (fraction of object surface samples within
//    `completeness_threshold` of a fused point), thresholds as fractions of the
//    object's bounding-box diagonal;
//  - the mesh's symmetric Chamfer distance to the object (mesh_metrics.h).
//
// The reconstruction is first aligned to the true cameras by a similarity
// (camera centres matched by image name, Umeyama), so an sfm stage that ran
// COLMAP is scored in the true frame. Points and mesh parts outside the
// object's bounding box grown by `crop_margin` (ground, background) are left
// out of accuracy and of the mesh-to-truth half of the Chamfer distance;
// the true occluders (ground, blockers) count as true surface.
#pragma once

#include <string>
#include <vector>

#include "core/json.h"

namespace relight {

// Thresholds of the evaluation.
struct MvsEvaluationOptions {
  double depth_tolerance = 0.01;         // of each view's true depth range (over the object; over the scene)
  std::string map_type;                  // maps scored: empty = geometric if present, else photometric; or a type
                                         // such as geometric_unfiltered (mvs_workspace.h) for diagnosis
  bool intersect_planes = true;          // compare along the true point's ray (our pixel's plane intersected with
                                         // it) rather than at our pixel centre (up to half a pixel beside it)
  int edge_band_px = 3;                  // object pixels this close (true image pixels, Chebyshev) to a non-object
                                         // pixel or a true depth step > 2% count as silhouette/edge pixels
  double accuracy_threshold = 0.005;     // of the object's bounding-box diagonal
  double completeness_threshold = 0.01;  // of the object's bounding-box diagonal
  double crop_margin = 0.1;              // bounding-box growth (of the diagonal) that counts as the object
  size_t surface_samples = 100000;       // samples for completeness and Chamfer
};

// Depth-map score of one view.
struct ViewDepthScore {
  std::string name;
  size_t object_pixels = 0;          // pixels of the object in the view
  double object_depth_range = 0;     // max - min true depth over the object's pixels
  double scene_depth_range = 0;      // max - min true depth over every pixel with a true depth
  double completeness = 0;           // fraction of the object's pixels within tolerance × object_depth_range
  double completeness_scene = 0;     // fraction of the object's pixels within tolerance × scene_depth_range
  double missing = 0;                // fraction of them without a depth
  size_t visible_pixels = 0;         // pixels with a true depth (object, ground, blockers)
  double completeness_visible = 0;   // fraction of the visible pixels within tolerance × scene_depth_range
  double edge_fraction = 0;          // fraction of them in the silhouette/edge band
  double completeness_interior = 0;  // completeness (object range) over the pixels outside the band
  double completeness_edge = 0;      // ... inside the band
  double median_error = 0;           // median |error| / true depth range over object pixels with a depth
  double median_signed_error = 0;    // median (ours - true) / true depth range (a bias shows here)
};

// All scores (lengths in the ground truth's units).
struct MvsEvaluation {
  std::string map_type;  // depth maps scored ("geometric" or "photometric")
  double diagonal = 0;   // of the true object's bounding box
  double scale = 1;      // of the similarity that aligned the reconstruction
  std::vector<ViewDepthScore> views;
  double mean_depth_completeness = 0;  // tolerance: of the view's depth range over the object
  double min_depth_completeness = 0;
  double mean_depth_completeness_scene = 0;  // tolerance: of the view's depth range over the scene (issue 9)
  double min_depth_completeness_scene = 0;
  double mean_depth_completeness_visible = 0;  // scene range, over every visible pixel (object and ground)
  double min_depth_completeness_visible = 0;
  double mean_missing = 0;                // object pixels without a depth
  double mean_completeness_interior = 0;  // object range, outside / inside the edge band
  double mean_completeness_edge = 0;
  size_t fused_points = 0;  // inside the object's box
  double fused_accuracy = 0;
  double fused_completeness = 0;
  double fused_mean_distance = 0;  // mean distance of the fused points to the true surfaces
  bool has_mesh = false;
  double chamfer = 0;  // symmetric
  double chamfer_mesh_to_truth = 0;
  double chamfer_truth_to_mesh = 0;

  OrderedJson ToJson() const;
  // A few lines for logs and docs.
  std::string BriefReport() const;
};

// Scores `<mvs_dir>` (dense/, fused.ply, meshed.ply) against `<ground_truth_dir>`. Throws UserError when
// a required file is missing or no image matches the true cameras by name.
MvsEvaluation EvaluateMvs(const std::string& mvs_dir, const std::string& ground_truth_dir,
                          const MvsEvaluationOptions& options = {});

}  // namespace relight
