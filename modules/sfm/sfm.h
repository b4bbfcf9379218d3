// The `sfm` stage: camera poses and intrinsics of the ingested photos.
//
// mode=colmap drives the COLMAP CLI step by step (feature_extractor with CPU
// SIFT, a matcher chosen by collection size, mapper, image_undistorter; see
// ../shared/COLMAP.md for the measured pitfalls), keeps the largest model and
// rotates it so the mean camera up direction (−y of the images) is +Z.
// The ground-truth mode copies the true cameras (a folder the stage's main
// gives); mode=model takes a user's COLMAP model. Every mode writes the same
// outputs (docs/FORMATS.md):
//   sparse/        COLMAP binary model, world frame, image names = photo names of the ingest manifest
//   sparse_txt/    the same as text
//   dense/         COLMAP undistorted workspace (images/, sparse/, stereo/) in the world frame, for MVS
//   sfm_summary.json  registered / dropped photos and why, reprojection error, world_from_colmap, timings
//   colmap/        COLMAP's raw mapper models (sparse/N, COLMAP frame) and, with sfm.keep_database, database.db
//
// World frame: COLMAP's frame rotated about the origin (no scale, no
// translation) so that the mean over registered images of the camera up
// direction −y (in world coordinates −R^T·e_y) becomes +Z; recorded as
// world_from_colmap. Cameras looking down at an object from around it give
// the true vertical; a one-sided collection tilted up or down leans by its
// mean tilt.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "geometry/reconstruction.h"
#include "ingest/ingest.h"
#include "sfm/sfm_options.h"

namespace relight {

// What happened to one photo of the collection.
struct SfmPhoto {
  std::string name;         // photo name (ingest manifest; image name in sparse/)
  std::string colmap_name;  // file name COLMAP saw (dense/images/)
  bool registered = false;
  int num_keypoints = -1;       // SIFT features (-1: not extracted, e.g. given cameras)
  int num_matched_photos = -1;  // photos with verified matches (-1: unknown)
  std::string reason;           // why it is not registered
  bool unstable = false;        // a mapper run that agrees overall placed it differently, or its pairs contradict it
  int pairs_checked = 0;        // its verified photo pairs checked against the kept model (model_consensus.h)
  int pairs_agreeing = 0;       // ... whose matches the model's epipolar geometry explains (fewer than half: left out)
};

// One run of COLMAP's incremental mapper (model_consensus.h), for the summary.
struct SfmMapperRun {
  std::string init_pair;                 // first pair, "a.jpg + b.jpg", or "COLMAP's choice"
  int num_models = 0;                    // models the run built
  int num_registered = 0;                // photos in its largest model
  int split_off_photos = 0;              // photos only in its smaller models (SplitOffPhotos)
  double mean_reprojection_error_px = 0;
  double seconds = 0;
  std::vector<int> agrees_with;          // indices of the runs whose models agree with this one's
  int pairs_checked = 0;                 // verified photo pairs of its model checked against their own rotation
  int pairs_agreeing = 0;                // of those, pairs that agree with the model
};

// Result of the stage (Ceres-style summary).
struct SfmSummary {
  std::string mode;
  std::string matcher;            // matcher used (colmap mode)
  int64_t num_pairs_matched = -1;  // photo pairs whose descriptors were compared (our matchers; -1: COLMAP's)
  std::string mapper;             // "incremental" or "hierarchical" (colmap mode)
  std::string shared_intrinsics;  // "single" or "per_image" (colmap mode)
  std::string refine_intrinsics;  // "mapping", "final" or "never" (colmap mode)
  bool principal_point_refined = false;  // in the final bundle adjustment (colmap mode)
  int num_photos = 0;
  int num_registered = 0;
  int num_models = 0;  // reconstructions the kept mapper run produced (the largest is kept)
  int split_off_photos = 0;                // photos only in the kept run's smaller models
  std::vector<SfmMapperRun> mapper_runs;   // colmap mode: every mapper run
  int chosen_run = -1;                     // index of the kept run
  // colmap mode: agreed (two runs and the photo pairs agree) | consistent (the photo pairs agree, no consistent
  // run disagrees) | unchecked (too few pairs to check, no second run) | disagreed | inconsistent | none.
  std::string consensus;
  size_t num_points3d = 0;
  double mean_reprojection_error_px = 0;
  Sim3 world_from_colmap;  // applied to COLMAP's frame to get the world frame
  std::vector<SfmPhoto> photos;
  std::vector<std::pair<std::string, double>> step_seconds;  // step name -> wall seconds
  double seconds = 0;
  std::string failure;  // why the stage stopped (empty: it did not)

  std::vector<std::string> UnregisteredNames() const;
  // One paragraph for the log.
  std::string BriefReport() const;
};

struct SfmInputs {
  std::string ingest_dir;  // the ingest stage's folder
  // Modes other than colmap and model: the COLMAP model folder of the cameras to use (the stage's main resolves
  // the ground_truth mode to the true cameras' folder); the model mode takes sfm.model.
  std::string given_cameras_dir;
};

// Runs the stage, writing into `output_dir` (exists). `threads` > 0 limits COLMAP's threads.
SfmSummary RunSfm(const SfmOptions& options, const SfmInputs& inputs, const std::string& output_dir,
                  int threads = 0);

// The rotation (about the origin) that takes the mean camera up direction
// (−y of the images, in world coordinates) to +Z. Identity when the cameras
// disagree so much that the mean vanishes.
Sim3 UpAlignment(const Reconstruction& reconstruction);

// Removes the images whose camera COLMAP would call bogus (its own mapper's limits): a focal length outside
// [kMinFocalRatio, kMaxFocalRatio] x the longer image side, or a distortion coefficient beyond kMaxDistortion in
// magnitude; their observations leave the tracks (points left with fewer than 2 go). Returns image name -> reason.
// The mapper applies these limits only while it refines intrinsics; a final bundle adjustment can still reach
// such a camera for a photo that few matches constrain.
inline constexpr double kMinFocalRatio = 0.1;
inline constexpr double kMaxFocalRatio = 10;
inline constexpr double kMaxDistortion = 1;
std::map<std::string, std::string> RemoveImplausibleCameras(Reconstruction* model);
// Removes the named images and their observations (points left with fewer than 2 go; other images' references to
// removed points are cleared).
void RemoveImages(const std::set<std::string>& names, Reconstruction* model);

// Fits a model to the ingested photos: images are matched by manifest name,
// else by the file name in <ingest>/images; they are renamed to the manifest
// name; cameras are rescaled to the ingested image size. Images not in the
// manifest are removed and returned.
std::vector<std::string> ConformToPhotos(const std::vector<IngestedPhoto>& photos, const std::string& where,
                                         Reconstruction* model);

// Reads the Middlebury camera file (`templeSR_par.txt`: a count line, then per
// line name, K (9), R (9), t (3), P = K[R t]) as a COLMAP-convention model with
// PINHOLE cameras of size `width`×`height`.
Reconstruction ReadMiddleburyCameras(const std::string& path, int width, int height);

// Writes sfm_summary.json.
void WriteSfmSummary(const SfmSummary& summary, const std::string& path);

}  // namespace relight
