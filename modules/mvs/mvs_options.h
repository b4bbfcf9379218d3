// Options of the `mvs` stage: dense depth and normal maps by PatchMatch
// multi-view stereo on the sfm stage's undistorted workspace, fused into a
// point cloud and meshed with COLMAP's tools (docs/FORMATS.md, `mvs` row).
#pragma once

#include <string>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kMvsStage{
    "mvs", "Dense geometry: CPU PatchMatch multi-view stereo, COLMAP stereo fusion and Poisson meshing", 7,
    /*shardable=*/true};

struct MvsOptions {
  // --- engine and resolution
  std::string engine = "patchmatch";  // patchmatch: ours (CPU); colmap: COLMAP's patch_match_stereo (needs CUDA).
  int max_image_size = 1000;          // Longest side of the depth maps in pixels; 0 keeps the undistorted size.
  // --- source views (per reference image, from the sparse model)
  int max_source_images = 8;                  // Source views per reference image (cost grows linearly).
  double min_triangulation_angle_deg = 2.0;   // Shared points seen under a smaller angle do not count; the
                                              // others count (1 + cos angle) / 2 (view_selection.h).
  int min_shared_points = 5;                  // A source view needs at least this many (weighted) shared points.
  // --- matching cost (bilateral-weighted NCC, Schönberger et al. 2016 §4.1)
  // The window is smaller than COLMAP's (radius 5, σ 5): near silhouettes, depth edges and on curved or
  // slanted surfaces a wide window moves the cost minimum off the true depth (docs/TUNING.md).
  int window_radius = 3;        // Half size of the matching window in pixels.
  int window_step = 1;          // Sample every `window_step`-th pixel of the window (1: 49 samples for radius 3).
  double sigma_color = 0.2;     // Bilateral weight: grey-level scale (images in [0, 1]).
  double sigma_spatial = 2.0;   // Bilateral weight: spatial scale in pixels.
  int num_best_views = 3;       // Cost of a hypothesis = mean over its this-many best source views (Galliani 2015).
  // --- PatchMatch iterations (red-black propagation + random refinement)
  int num_iterations = 3;             // Photometric iterations (each updates every pixel twice: black, red).
  bool geom_consistency = true;       // Second pass adding forward-backward reprojection error (COLMAP's geometric).
  int geom_iterations = 3;            // Iterations of the geometric pass, each against the sources' maps of the
                                      // one before (the first against their photometric maps).
  double geom_regularizer = 1.0;      // Weight of the reprojection error (pixels) against 1 - NCC.
  double geom_max_cost_px = 3.0;      // Reprojection errors are truncated at this many pixels.
  double depth_margin = 0.25;         // Depth search range = sparse depths' 1..99 percentiles widened by this fraction.
  int seed = 0;                       // Random seed (results do not depend on the thread count).
  // --- filtering of the final maps
  double filter_min_ncc = 0.2;                 // A view supports a pixel when its NCC reaches this value ...
  double filter_geom_max_error_px = 1.0;       // ... its reprojection error is at most this (geometric pass) ...
  double filter_min_triangulation_angle_deg = 2.0;  // ... and it sees the point under at least this angle.
  int filter_min_num_consistent = 2;           // Pixels supported by fewer source views are removed.
  int filter_min_segment_px = 20;              // Connected depth segments (steps < 2%) smaller than this are removed (0: off).
  // --- fusion (colmap stereo_fusion)
  int fusion_min_num_pixels = 5;           // Pixels (views) a fused point needs.
  double fusion_max_reproj_error_px = 2.0;  // Reprojection error for a pixel to join a point.
  double fusion_max_depth_error = 0.01;    // Relative depth error for a pixel to join a point.
  double fusion_max_normal_error_deg = 10.0;  // Normal angle for a pixel to join a point.
  // --- meshing
  std::string mesher = "colmap_poisson";  // colmap_poisson (screened Poisson, Kazhdan 2013) | cgal_poisson | none.
  int poisson_depth = 10;                 // Octree depth of colmap_poisson (detail vs. time and noise).
  double poisson_trim = 0.0;              // colmap_poisson density trim; 0 keeps the closed surface.
  bool close_holes = true;                // Triangulate the mesh's boundary loops (where the Poisson box clips it).
  bool write_preview = true;              // Render the mesh from the first camera into meshed_preview.png.

  void Declare(OptionTable* t) {
    t->Add("engine", &engine,
           "patchmatch: our CPU PatchMatch stereo; colmap: COLMAP's own patch_match_stereo, which needs a COLMAP "
           "built with CUDA (Debian's is not).")
        .Choices({"patchmatch", "colmap"});
    t->Add("max_image_size", &max_image_size,
           "Longest side of the depth maps in pixels (time grows with the pixel count); 0 keeps the undistorted size.")
        .Min(0);
    t->Add("max_source_images", &max_source_images,
           "Source views matched against each reference image; more views cost time linearly and help occlusions.")
        .Range(1, 64);
    t->Add("min_triangulation_angle_deg", &min_triangulation_angle_deg,
           "Sparse points shared with a candidate source view count only when seen under at least this angle.")
        .Range(0, 60)
        .Advanced();
    t->Add("min_shared_points", &min_shared_points,
           "A source view must share at least this many such sparse points with the reference image, each "
           "weighted by (1 + cos of its triangulation angle) / 2 (1 for close views, 0.5 at 90 deg, 0.1 at 143 deg).")
        .Min(1)
        .Advanced();
    t->Add("window_radius", &window_radius, "Half size of the NCC window in pixels (larger: smoother, slower).")
        .Range(1, 16);
    t->Add("window_step", &window_step, "Sample every n-th pixel of the window (2 halves the samples per axis).")
        .Range(1, 4)
        .Advanced();
    t->Add("sigma_color", &sigma_color, "Bilateral weight of the NCC window: grey-level scale (images in [0, 1]).")
        .Min(1e-3)
        .Advanced();
    t->Add("sigma_spatial", &sigma_spatial, "Bilateral weight of the NCC window: spatial scale in pixels.")
        .Min(0.1)
        .Advanced();
    t->Add("num_best_views", &num_best_views,
           "A hypothesis' cost is the mean of its best this-many source views (robust to occlusion).")
        .Range(1, 64)
        .Advanced();
    t->Add("num_iterations", &num_iterations, "PatchMatch iterations of the photometric pass.").Range(1, 20);
    t->Add("geom_consistency", &geom_consistency,
           "Run a second pass that adds the forward-backward reprojection error against the other depth maps.");
    t->Add("geom_iterations", &geom_iterations,
           "PatchMatch iterations of the geometric pass, each against the other views' maps of the one "
           "before. Each costs about a third of the photometric pass; raise it when changing light or "
           "weak texture leaves the depth maps noisy.")
        .Range(1, 20)
        .OnlyWhen("geom_consistency", {"true"});
    t->Add("geom_regularizer", &geom_regularizer,
           "Weight of the reprojection error (pixels) against 1 - NCC in the geometric pass; higher trusts the "
           "other views' depths more than the photometric match.")
        .Min(0)
        .Advanced()
        .OnlyWhen("geom_consistency", {"true"});
    t->Add("geom_max_cost_px", &geom_max_cost_px, "Reprojection errors are truncated at this many pixels.")
        .Min(0.1)
        .Advanced()
        .OnlyWhen("geom_consistency", {"true"});
    t->Add("depth_margin", &depth_margin,
           "The depth search range is the 1st..99th percentile of the sparse depths widened by this fraction.")
        .Range(0, 4)
        .Advanced();
    t->Add("seed", &seed, "Random seed of the PatchMatch sampling (results do not depend on threads).")
        .Min(0)
        .Advanced();
    t->Add("filter_min_ncc", &filter_min_ncc, "A source view supports a pixel when its NCC is at least this.")
        .Range(-1, 1)
        .Advanced();
    t->Add("filter_geom_max_error_px", &filter_geom_max_error_px,
           "... and (geometric pass) its forward-backward reprojection error is at most this many pixels.")
        .Min(0)
        .Advanced()
        .OnlyWhen("geom_consistency", {"true"});
    t->Add("filter_min_triangulation_angle_deg", &filter_min_triangulation_angle_deg,
           "... and it sees the point under at least this triangulation angle.")
        .Range(0, 60)
        .Advanced();
    t->Add("filter_min_num_consistent", &filter_min_num_consistent,
           "Depth-map pixels supported by fewer source views are removed.")
        .Min(1)
        .Advanced();
    t->Add("filter_min_segment_px", &filter_min_segment_px,
           "Connected depth-map segments (4-neighbours within 2% in depth) smaller than this are removed; 0 disables.")
        .Min(0)
        .Advanced();
    t->Add("fusion_min_num_pixels", &fusion_min_num_pixels,
           "colmap stereo_fusion: pixels that must agree on a fused point.")
        .Min(1)
        .Advanced();
    t->Add("fusion_max_reproj_error_px", &fusion_max_reproj_error_px,
           "colmap stereo_fusion: reprojection error in pixels for a pixel to join a point.")
        .Min(0)
        .Advanced();
    t->Add("fusion_max_depth_error", &fusion_max_depth_error,
           "colmap stereo_fusion: relative depth error for a pixel to join a point.")
        .Min(0)
        .Advanced();
    t->Add("fusion_max_normal_error_deg", &fusion_max_normal_error_deg,
           "colmap stereo_fusion: normal angle in degrees for a pixel to join a point.")
        .Range(0, 180)
        .Advanced();
    t->Add("mesher", &mesher,
           "colmap_poisson: COLMAP's screened Poisson (fast, fine); cgal_poisson: CGAL's Poisson with "
           "Delaunay refinement (coarser at CGAL's default triangle sizes); none: stop after fusion.")
        .Choices({"colmap_poisson", "cgal_poisson", "none"});
    t->Add("poisson_depth", &poisson_depth, "colmap_poisson: octree depth (more: finer detail, more noise, slower).")
        .Range(5, 14)
        .OnlyWhen("mesher", {"colmap_poisson"});
    t->Add("poisson_trim", &poisson_trim,
           "colmap_poisson: remove surface of sample density below this (0 keeps the closed surface; COLMAP uses 10).")
        .Range(0, 20)
        .Advanced()
        .OnlyWhen("mesher", {"colmap_poisson"});
    t->Add("close_holes", &close_holes,
           "Triangulate every boundary loop of the mesh (where COLMAP's Poisson surface is clipped by its bounding "
           "box at unobserved sides), so the mesh is closed.");
    t->Add("write_preview", &write_preview, "Render the mesh from the first camera into meshed_preview.png.")
        .NotInKey()
        .Advanced();
  }
  void Check() const {
    if (window_step > window_radius) {
      RELIGHT_USER_ERROR() << "mvs.window_step (" << window_step << ") is larger than mvs.window_radius ("
                           << window_radius << "): lower the step or raise the radius";
    }
    if (max_image_size != 0 && max_image_size < 32) {
      RELIGHT_USER_ERROR() << "mvs.max_image_size " << max_image_size
                           << " is too small for stereo: use at least 32 pixels, or 0 for the full size";
    }
  }
};

// Passes of per-image depth maps a sharded run (--shard, --step) can be split into, each reading the maps
// of the pass before: photometric, each geometric iteration, filtering. 0: the engine cannot be sharded.
inline int MvsShardSteps(const MvsOptions& o) {
  if (o.engine != "patchmatch") return 0;
  return o.geom_consistency ? o.geom_iterations + 2 : 1;
}

}  // namespace relight
