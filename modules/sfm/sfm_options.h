// Options of the `sfm` stage: camera poses and intrinsics of the ingested
// photos, in the project's +Z-up world frame (docs/FORMATS.md).
#pragma once

#include <string>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kSfmStage{
    "sfm", "Structure from motion with COLMAP: camera poses and intrinsics in a +Z-up world frame", 5};

struct SfmOptions {
  std::string mode = "colmap";  // colmap: run COLMAP; ground_truth: <ingest>/ground_truth cameras; model: `model`.
  std::string model;            // COLMAP model folder (cameras/images/points3D .bin or .txt) for mode=model.
  std::string camera_model = "SIMPLE_RADIAL";  // COLMAP camera model of new cameras.
  std::string shared_intrinsics = "auto";      // auto | single | per_image: one camera for all photos or one each.
  bool use_exif_focal = true;                  // Start from the EXIF focal length (ingest's focal_px) as a prior.
  std::string matcher = "auto";                // auto | exhaustive | retrieval | sequential | spatial | vocab_tree.
  int exhaustive_max_photos = 100;             // auto: exhaustive matching up to this many photos.
  int retrieval_neighbors = 30;                // retrieval: most similar photos each photo is matched with.
  std::string vocab_tree;                      // Vocabulary-tree file (COLMAP's FLANN format) for vocab_tree matching.
  int sequential_overlap = 10;                 // Neighbours each photo is matched with by the sequential matcher.
  int max_image_size = 1600;                // Longest side SIFT sees (pixels); larger photos are downscaled for SIFT.
  int max_num_features = 8192;              // Grey SIFT features per photo, and at most as many colour ones.
  int min_model_size = 3;                   // Smallest reconstruction COLMAP keeps (photos).
  int abs_pose_min_num_inliers = 15;        // Inliers needed to register a photo (COLMAP default 30; see COLMAP.md).
  double abs_pose_min_inlier_ratio = 0.25;  // Inlier ratio needed to register a photo.
  std::string refine_intrinsics =
      "auto";  // When focal length and distortion are refined: auto | mapping | final | never.
  std::string refine_principal_point = "auto";  // auto | never | always: principal point refined in the final BA.
  int min_registered = 3;                       // Fewer registered photos than this is an error.
  bool allow_partial = false;                   // Go on when SfM is partial (< half registered, split) or unreliable.
  std::string mapper = "auto";       // auto | incremental | hierarchical: COLMAP's mapper or its divided one.
  int max_mapper_runs = 4;           // Mapper runs from different first pairs, until two agree.
  bool align_up = true;              // Rotate so that the mean camera up (-y of the images) is +Z.
  int undistort_max_image_size = 0;  // Longest side of dense/ images; 0 keeps the ingested size.
  int seed = 0;                      // COLMAP's random seed (runs still vary slightly with threads).
  bool keep_database = false;        // Keep colmap/database.db (features, matches) for debugging.

  void Declare(OptionTable* t) {
    t->Add("mode", &mode,
           "colmap: reconstruct with COLMAP; ground_truth: copy the cameras of <ingest>/ground_truth; "
           "model: use the COLMAP model folder given by sfm.model.")
        .Choices({"colmap", "ground_truth", "model"});
    t->Add("model", &model, "COLMAP model folder (cameras/images/points3D as .bin or .txt) for sfm.mode=model.")
        .InputDir()
        .OnlyWhen("mode", {"model"});
    t->Add("camera_model", &camera_model,
           "COLMAP camera model; SIMPLE_RADIAL is the most stable for few photos, OPENCV fits wide lenses.")
        .Choices({"SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV"})
        .OnlyWhen("mode", {"colmap"});
    t->Add("shared_intrinsics", &shared_intrinsics,
           "single: one camera for all photos (same camera and size: more stable); per_image: one each "
           "(Internet photos); auto: single when all photos share size and EXIF camera.")
        .Choices({"auto", "single", "per_image"})
        .OnlyWhen("mode", {"colmap"});
    t->Add("use_exif_focal", &use_exif_focal, "Initialise the focal length from EXIF (ingest's focal_px) as a prior.")
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("matcher", &matcher,
           "Which photo pairs are matched. auto: exhaustive up to exhaustive_max_photos, else vocab_tree "
           "when vocab_tree is set, else retrieval (each photo with its most similar ones); sequential: "
           "video frames; spatial: GPS in EXIF.")
        .Choices({"auto", "exhaustive", "retrieval", "sequential", "spatial", "vocab_tree"})
        .OnlyWhen("mode", {"colmap"});
    t->Add("exhaustive_max_photos", &exhaustive_max_photos,
           "auto matcher: exhaustive matching (cost grows with the square of the photos) up to this many photos.")
        .Min(3)
        .Advanced()
        .OnlyWhen("mode", {"colmap"})
        .OnlyWhen("matcher", {"auto"});
    t->Add("retrieval_neighbors", &retrieval_neighbors,
           "retrieval matcher: the most similar photos each photo is matched with; a photo left with fewer "
           "verified partners than the median photo is matched with more (its partners' partners, then its next "
           "most similar), while that finds it partners, up to 4 times as many. Raise it when photos of a large "
           "collection stay unregistered; matching time grows with it.")
        .Min(2)
        .Advanced()
        .OnlyWhen("mode", {"colmap"})
        .OnlyWhen("matcher", {"auto", "retrieval"});
    t->Add("vocab_tree", &vocab_tree, "Vocabulary-tree file for vocab_tree matching (COLMAP's download page).")
        .InputFile()
        .OnlyWhen("mode", {"colmap"})
        .OnlyWhen("matcher", {"auto", "vocab_tree"});
    t->Add("sequential_overlap", &sequential_overlap, "Sequential matcher: neighbours matched per photo.")
        .Min(1)
        .Advanced()
        .OnlyWhen("mode", {"colmap"})
        .OnlyWhen("matcher", {"sequential"});
    t->Add("max_image_size", &max_image_size,
           "Longest side in pixels SIFT works on; larger costs memory and time, smaller loses features.")
        .Min(100);
    t->Add("max_num_features", &max_num_features,
           "Grey SIFT features per photo; SIFT features of the photo's colour (log-chromaticity), which survive "
           "changes of light, are added, at most as many. Fewer match faster, more register weakly "
           "textured photos.")
        .Min(100)
        .Advanced();
    t->Add("min_model_size", &min_model_size, "Smallest reconstruction (photos) COLMAP keeps.")
        .Min(2)
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("abs_pose_min_num_inliers", &abs_pose_min_num_inliers,
           "Inlier matches needed to register a photo; lower registers weakly linked photos, at some risk.")
        .Min(6)
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("abs_pose_min_inlier_ratio", &abs_pose_min_inlier_ratio, "Inlier ratio needed to register a photo.")
        .Range(0, 1)
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("refine_intrinsics", &refine_intrinsics,
           "mapping: refine focal length and distortion during incremental mapping (COLMAP's default; needed "
           "without EXIF); final: keep the EXIF focal fixed while mapping (robust on scenes dominated by a "
           "plane), then refine in one final bundle adjustment; never: keep them; auto: final when every photo "
           "has an EXIF focal length, else mapping.")
        .Choices({"auto", "mapping", "final", "never"})
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("refine_principal_point", &refine_principal_point,
           "Refine the principal point in a final bundle adjustment (mapping keeps it at the image centre, where "
           "it is unstable): auto refines it when one camera is shared by at least 10 registered photos, which "
           "constrain it; never keeps the image centre; always refines every camera's (risky with per-photo "
           "cameras and few photos).")
        .Choices({"auto", "never", "always"})
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("min_registered", &min_registered, "Fewer registered photos than this is an error.").Min(2);
    t->Add("allow_partial", &allow_partial,
           "Go on with the largest model when fewer than half of the photos register, when they split "
           "into separate models, or when mapper runs disagree; by default the stage stops and says "
           "which photos failed and why.");
    t->Add("mapper", &mapper,
           "incremental: COLMAP's mapper, one model grown photo by photo (time about photos^2.5); "
           "hierarchical: clusters mapped in parallel and merged (faster on large collections, cameras "
           "less accurate); auto: hierarchical from 300 photos.")
        .Choices({"auto", "incremental", "hierarchical"})
        .OnlyWhen("mode", {"colmap"});
    t->Add("max_mapper_runs", &max_mapper_runs,
           "Incremental mapping is repeated from different first pairs until two runs place the cameras the same "
           "way (a wrong reconstruction can look normal); at most this many runs. 1 skips the check (saves time "
           "on large collections).")
        .Range(1, 16)
        .Advanced()
        .OnlyWhen("mode", {"colmap"});
    t->Add("align_up", &align_up,
           "Rotate the COLMAP frame so the mean camera up (-y of the images) is +Z (colmap and model modes).")
        .Advanced()
        .OnlyWhen("mode", {"colmap", "model"});
    t->Add("undistort_max_image_size", &undistort_max_image_size,
           "Longest side of the undistorted dense/ images in pixels; 0 keeps the ingested size.")
        .Min(0)
        .Advanced();
    t->Add("seed", &seed, "COLMAP's random seed.").Min(0).Advanced().OnlyWhen("mode", {"colmap"});
    t->Add("keep_database", &keep_database, "Keep colmap/database.db (features and matches) for debugging.")
        .NotInKey()
        .Advanced();
  }
  void Check() const {
    if (mode == "model" && model.empty()) {
      RELIGHT_USER_ERROR() << "sfm.mode is 'model' but sfm.model is empty: set it to a COLMAP model folder";
    }
    if (matcher == "vocab_tree" && vocab_tree.empty()) {
      RELIGHT_USER_ERROR() << "sfm.matcher is vocab_tree but sfm.vocab_tree is empty: set it to a vocabulary-tree file";
    }
  }
};

}  // namespace relight
