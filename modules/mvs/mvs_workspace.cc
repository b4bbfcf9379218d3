#include "mvs/mvs_workspace.h"

#include <filesystem>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "mvs/colmap_mat.h"

namespace relight {
namespace fs = std::filesystem;

std::string MvsWorkspace::DepthMapPath(const std::string& image_name, const std::string& type) const {
  return StereoDir() + "/depth_maps/" + image_name + "." + type + ".bin";
}

std::string MvsWorkspace::NormalMapPath(const std::string& image_name, const std::string& type) const {
  return StereoDir() + "/normal_maps/" + image_name + "." + type + ".bin";
}

std::string MvsWorkspace::ReportPath(const std::string& image_name, const std::string& type) const {
  return StereoDir() + "/reports/" + image_name + "." + type + ".json";
}

bool MvsWorkspace::HasMaps(const std::string& image_name, const std::string& type) const {
  return fs::exists(NormalMapPath(image_name, type)) && fs::exists(DepthMapPath(image_name, type));
}

void MvsWorkspace::WriteMaps(const StereoView& view, const DepthNormalMap& map, const std::string& type) const {
  ColmapMat depth, normal;
  ToColmapMaps(map, view.K, &depth, &normal);
  const std::string normal_path = NormalMapPath(view.name, type);
  const std::string depth_path = DepthMapPath(view.name, type);
  EnsureDir(fs::path(normal_path).parent_path().string());
  EnsureDir(fs::path(depth_path).parent_path().string());
  WriteColmapMat(normal_path, normal);
  WriteColmapMat(depth_path, depth);
}

DepthNormalMap MvsWorkspace::ReadMaps(const StereoView& view, const std::string& type) const {
  const ColmapMat depth = ReadColmapMat(DepthMapPath(view.name, type));
  const ColmapMat normal = ReadColmapMat(NormalMapPath(view.name, type));
  if (depth.width != view.width || depth.height != view.height) {
    RELIGHT_USER_ERROR() << "'" << DepthMapPath(view.name, type) << "' is " << depth.width << "x" << depth.height
                         << ", expected " << view.width << "x" << view.height << "; delete it and rerun";
  }
  return FromColmapMaps(depth, normal, view.K, DepthMapPath(view.name, type));
}

void MvsWorkspace::RemoveMaps(const std::string& image_name, const std::string& type) const {
  std::error_code ec;  // missing files are fine
  fs::remove(DepthMapPath(image_name, type), ec);
  fs::remove(NormalMapPath(image_name, type), ec);
  fs::remove(ReportPath(image_name, type), ec);
}

namespace {

// Mirrors the regular files below `from` into `to` by hard links (copies when linking fails).
void MirrorTree(const std::string& from, const std::string& to) {
  EnsureDir(to);
  for (const auto& entry : fs::recursive_directory_iterator(from)) {
    const fs::path rel = fs::relative(entry.path(), from);
    const fs::path target = fs::path(to) / rel;
    if (entry.is_directory()) {
      EnsureDir(target.string());
      continue;
    }
    if (!entry.is_regular_file()) continue;
    std::error_code ec;
    if (fs::exists(target, ec)) {
      if (fs::equivalent(target, entry.path(), ec) ||
          fs::file_size(target, ec) == fs::file_size(entry.path(), ec)) {
        continue;
      }
      fs::remove(target, ec);
    }
    fs::create_hard_link(entry.path(), target, ec);
    std::error_code same_ec;
    if (ec && fs::equivalent(target, entry.path(), same_ec)) continue;  // linked by a shard running beside us
    if (ec) {
      AtomicFile copy(target.string());
      fs::copy_file(entry.path(), copy.temp_path(), fs::copy_options::overwrite_existing, ec);
      if (ec) {
        RELIGHT_USER_ERROR() << "cannot copy '" << entry.path().string() << "' into the mvs workspace: "
                             << ec.message();
      }
      copy.Commit();
    }
  }
}

}  // namespace

MvsWorkspace PrepareMvsWorkspace(const std::string& sfm_dir, const std::string& output_dir) {
  const std::string dense = JoinPath(sfm_dir, "dense");
  if (!fs::is_directory(JoinPath(dense, "images")) || !fs::is_directory(JoinPath(dense, "sparse"))) {
    RELIGHT_USER_ERROR() << "the sfm output '" << sfm_dir << "' has no undistorted workspace (dense/images and "
                         << "dense/sparse, written by colmap image_undistorter): rerun the sfm stage";
  }
  const bool has_model = (fs::exists(JoinPath(dense, "sparse/cameras.bin")) ||
                          fs::exists(JoinPath(dense, "sparse/cameras.txt")));
  if (!has_model) {
    RELIGHT_USER_ERROR() << "'" << JoinPath(dense, "sparse") << "' holds no COLMAP model (cameras, images, "
                         << "points3D as .bin or .txt): rerun the sfm stage";
  }
  MvsWorkspace ws;
  ws.dir = JoinPath(output_dir, "dense");
  MirrorTree(JoinPath(dense, "images"), ws.ImagesDir());
  MirrorTree(JoinPath(dense, "sparse"), ws.SparseDir());
  for (const char* sub : {"depth_maps", "normal_maps", "consistency_graphs", "reports"}) {
    EnsureDir(ws.StereoDir() + "/" + sub);
  }
  return ws;
}

void WritePatchMatchConfig(const MvsWorkspace& workspace, const std::vector<StereoView>& views,
                           const std::vector<ViewSelection>& plans) {
  std::ostringstream out;
  for (const ViewSelection& plan : plans) {
    if (!plan.skip_reason.empty()) continue;
    out << views[plan.ref].name << "\n";
    for (size_t k = 0; k < plan.sources.size(); ++k) out << (k ? ", " : "") << views[plan.sources[k]].name;
    out << "\n";
  }
  WriteFileAtomic(workspace.StereoDir() + "/patch-match.cfg", out.str());
}

void WriteFusionConfig(const MvsWorkspace& workspace, const std::vector<std::string>& image_names) {
  std::string text;
  for (const auto& name : image_names) text += name + "\n";
  WriteFileAtomic(workspace.StereoDir() + "/fusion.cfg", text);
}

Image LoadGrayImage(const MvsWorkspace& workspace, const StereoView& view) {
  const std::string path = workspace.ImagesDir() + "/" + view.name;
  // COLMAP ignores EXIF orientation; so must we, to match its cameras.
  const Image color = ReadImage(path, nullptr, /*apply_orientation=*/false);
  if (color.width != view.image_width || color.height != view.image_height) {
    RELIGHT_USER_ERROR() << "'" << path << "' is " << color.width << "x" << color.height << " but its camera in "
                         << workspace.SparseDir() << " is " << view.image_width << "x" << view.image_height
                         << ": the undistorted workspace is inconsistent; rerun the sfm stage";
  }
  Image gray(color.width, color.height, 1);
  for (size_t i = 0; i < gray.pixels.size(); ++i) {
    const float* p = &color.pixels[i * color.channels];
    gray.pixels[i] = color.channels >= 3 ? 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2] : p[0];
  }
  if (gray.width != view.width || gray.height != view.height) gray = ResizeImage(gray, view.width, view.height);
  return gray;
}

}  // namespace relight
