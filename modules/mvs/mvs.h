// The `mvs` stage: dense geometry from the sfm stage's undistorted workspace.
//
//   1. A COLMAP workspace of our own in <output>/dense (mvs_workspace.h).
//   2. Depth + normal maps per registered image: our PatchMatch stereo
//      (patch_match.h; a photometric pass, a geometric-consistency pass
//      against the photometric maps, then filtering against the sources'
//      geometric maps), or COLMAP's patch_match_stereo when built with CUDA.
//      Each image's maps are written atomically as they finish, so a killed
//      run resumes image by image.
//   3. `colmap stereo_fusion` → fused.ply (points with normals and colours).
//   4. Poisson meshing (`colmap poisson_mesher` or CGAL) → meshed.ply, plus
//      meshed_preview.png and mvs_summary.json.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "mvs/mvs_options.h"
#include "mvs/mvs_workspace.h"

namespace relight {

// One registered image.
struct MvsImageReport {
  std::string name;
  int width = 0;                      // depth-map size
  int height = 0;
  std::vector<std::string> sources;   // source views, best first
  double depth_min = 0;               // search range of camera z
  double depth_max = 0;
  std::string skipped;                // why it is no reference image (empty when it is)
  bool reused = false;                // its final maps came from an earlier, interrupted run
  double seconds_photometric = 0;
  double seconds_geometric = 0;
  double mean_cost = 0;               // final aggregated matching cost over textured pixels
  double valid_fraction = 0;          // pixels with a depth after filtering
};

// Result of the stage (Ceres-style summary).
struct MvsSummary {
  std::string engine;
  int num_images = 0;                 // registered images in the model
  int num_reference_images = 0;       // images with depth maps
  int num_reused = 0;                 // of which finished by an earlier run
  double reference_megapixels = 0;    // depth-map pixels of all reference images (MP)
  std::vector<MvsImageReport> images;
  size_t fused_points = 0;
  std::string mesher;
  size_t mesh_vertices = 0;
  size_t mesh_faces = 0;
  int holes_filled = 0;               // boundary loops closed (close_holes)
  size_t mesh_boundary_edges = 0;     // after hole filling
  size_t mesh_nonmanifold_edges = 0;
  bool mesh_closed = false;
  std::vector<std::pair<std::string, double>> step_seconds;  // step name -> wall seconds
  double seconds = 0;

  // One paragraph for the log.
  std::string BriefReport() const;
};

// Our PatchMatch on every registered image of `workspace` (engine patchmatch), resuming finished images.
// Writes the maps, patch-match.cfg, fusion.cfg and per-image reports; fills `summary->images`.
// Returns the map type fusion reads ("geometric" or "photometric"). With an active `shard`: only pass
// `shard.step` (MvsShardSteps) of the shard's reference images, and no configuration files.
std::string ComputeDepthMaps(const MvsOptions& options, const MvsWorkspace& workspace, MvsSummary* summary,
                             const ShardSpec& shard = {});

// Runs the stage on an sfm output folder, writing into `output_dir` (exists). The depth maps use the TBB
// threads the caller allows; COLMAP's fusion and Poisson run on one thread (colmap_tools.h). With an active
// `shard`, the shard's depth maps of one pass only (ComputeDepthMaps), no fusion, meshing or summary.
struct MvsInputs {
  std::string sfm_dir;  // the sfm stage's folder
};
MvsSummary RunMvs(const MvsOptions& options, const MvsInputs& inputs, const std::string& output_dir,
                  const ShardSpec& shard = {});

// Writes mvs_summary.json.
void WriteMvsSummary(const MvsSummary& summary, const std::string& path);

}  // namespace relight
