// The stage's own COLMAP dense workspace, `<output>/dense/`, laid out as
// `colmap image_undistorter` lays it out, so COLMAP's `stereo_fusion` and
// `patch_match_stereo` run on it:
//
//   images/                     hard links to <sfm>/dense/images (copies across file systems)
//   sparse/                     hard links to <sfm>/dense/sparse (COLMAP model, PINHOLE cameras)
//   stereo/depth_maps/<image name>.<type>.bin   (colmap_mat.h, COLMAP's pixel convention), type
//       photometric (pass 1), geometric_unfiltered (pass 2; geometric_unfiltered_<k> for its earlier
//       iterations, deleted once the last is complete), geometric (filtered; what fusion reads)
//   stereo/normal_maps/<image name>.<type>.bin
//   stereo/consistency_graphs/  (empty; COLMAP 3.8's fusion does not read them)
//   stereo/patch-match.cfg      per reference image: its name, then its source names, comma-separated
//   stereo/fusion.cfg           the images whose maps enter fusion
//   stereo/reports/<image name>.<type>.json   per-image statistics (for resuming and the summary)
//
// The sfm stage's cache entry is never written to: it is immutable.
#pragma once

#include <string>
#include <vector>

#include "image/image.h"
#include "mvs/stereo_view.h"
#include "mvs/view_selection.h"

namespace relight {

struct MvsWorkspace {
  std::string dir;  // <output>/dense

  std::string ImagesDir() const { return dir + "/images"; }
  std::string SparseDir() const { return dir + "/sparse"; }
  std::string StereoDir() const { return dir + "/stereo"; }
  // stereo/depth_maps/<image>.<type>.bin.
  std::string DepthMapPath(const std::string& image_name, const std::string& type) const;
  // stereo/normal_maps/<image>.<type>.bin
  std::string NormalMapPath(const std::string& image_name, const std::string& type) const;
  // stereo/reports/<image>.<type>.json
  std::string ReportPath(const std::string& image_name, const std::string& type) const;
  // Both maps of an image exist (written atomically, normal first, so the depth map marks completion).
  bool HasMaps(const std::string& image_name, const std::string& type) const;
  // Writes the normal map, then the depth map (COLMAP's convention), atomically each.
  void WriteMaps(const StereoView& view, const DepthNormalMap& map, const std::string& type) const;
  // Reads both maps back into the pixel-centre convention; throws UserError when missing or malformed.
  DepthNormalMap ReadMaps(const StereoView& view, const std::string& type) const;
  // Deletes both maps and the report of an image (depth map first, so a half-removed pair is not complete).
  void RemoveMaps(const std::string& image_name, const std::string& type) const;
};

// Creates `<output_dir>/dense` from `<sfm_dir>/dense` (hard links, else copies). Throws UserError when the
// sfm output has no undistorted workspace.
MvsWorkspace PrepareMvsWorkspace(const std::string& sfm_dir, const std::string& output_dir);

// Writes stereo/patch-match.cfg (the chosen sources of every reference image).
void WritePatchMatchConfig(const MvsWorkspace& workspace, const std::vector<StereoView>& views,
                           const std::vector<ViewSelection>& plans);
// Writes stereo/fusion.cfg listing `image_names`.
void WriteFusionConfig(const MvsWorkspace& workspace, const std::vector<std::string>& image_names);

// Loads an undistorted image as grey (Rec. 601 luma of the encoded values) at the view's processing size.
// Throws UserError naming the file when unreadable or not of the camera's size.
Image LoadGrayImage(const MvsWorkspace& workspace, const StereoView& view);

}  // namespace relight
