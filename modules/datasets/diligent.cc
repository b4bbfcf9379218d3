#include "datasets/diligent.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "geometry/mesh_io.h"
#include "geometry/primitives.h"
#include "geometry/reconstruction.h"
#include "image/image.h"

namespace relight {
namespace fs = std::filesystem;

bool IsDiligentFolder(const std::string& folder) {
  return fs::exists(JoinPath(folder, "filenames.txt")) && fs::exists(JoinPath(folder, "light_directions.txt")) &&
         fs::exists(JoinPath(folder, "mask.png"));
}

Eigen::Vector3d DiligentToWorld(const Eigen::Vector3d& d) { return {d.x(), -d.z(), d.y()}; }

namespace {

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  if (!in) RELIGHT_USER_ERROR() << "cannot read '" << path << "'; the DiLiGenT folder is incomplete";
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

std::vector<Eigen::Vector3d> ReadTriples(const std::string& path, size_t expected) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& line : ReadLines(path)) {
    std::istringstream s(line);
    Eigen::Vector3d v;
    if (!(s >> v.x() >> v.y() >> v.z())) RELIGHT_USER_ERROR() << "'" << path << "': malformed line '" << line << "'";
    out.push_back(v);
  }
  if (out.size() != expected) {
    RELIGHT_USER_ERROR() << "'" << path << "' has " << out.size() << " lines for " << expected
                         << " photos in filenames.txt";
  }
  return out;
}

}  // namespace

DiligentScene ImportDiligent(const std::string& folder, const std::string& output,
                             const DiligentImportOptions& options) {
  if (!IsDiligentFolder(folder)) {
    RELIGHT_USER_ERROR() << "'" << folder
                         << "' is not a DiLiGenT object folder (needs filenames.txt, light_directions.txt, mask.png)";
  }
  const std::vector<std::string> names = ReadLines(JoinPath(folder, "filenames.txt"));
  const std::vector<Eigen::Vector3d> dirs = ReadTriples(JoinPath(folder, "light_directions.txt"), names.size());
  std::vector<Eigen::Vector3d> intensities(names.size(), Eigen::Vector3d::Ones());
  if (fs::exists(JoinPath(folder, "light_intensities.txt"))) {
    intensities = ReadTriples(JoinPath(folder, "light_intensities.txt"), names.size());
  }

  // Ball from the mask.
  const Image mask = ReadImage(JoinPath(folder, "mask.png"));
  double sx = 0, sy = 0, area = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y, 0) > 0.5f) {
        sx += x + 0.5;
        sy += y + 0.5;
        area += 1;
      }
  if (area < 100) RELIGHT_USER_ERROR() << "'" << folder << "/mask.png' marks fewer than 100 pixels";
  DiligentScene scene;
  scene.center_px = {sx / area, sy / area};
  scene.radius_px = std::sqrt(area / M_PI);

  const std::string images = JoinPath(output, "images");
  const std::string gt = JoinPath(output, "ground_truth");
  EnsureDir(images);
  EnsureDir(gt);
  int width = 0, height = 0;
  for (const auto& name : names) {
    const std::string src = JoinPath(folder, name);
    const ImageMetadata meta = ReadImageMetadata(src);
    if (width == 0) {
      width = meta.width;
      height = meta.height;
    } else if (meta.width != width || meta.height != height) {
      RELIGHT_USER_ERROR() << "'" << src << "' is " << meta.width << "x" << meta.height << ", the others " << width
                           << "x" << height;
    }
    const std::string dst = JoinPath(images, name);
    std::error_code ec;
    fs::remove(dst, ec);
    fs::create_hard_link(src, dst, ec);
    if (ec) WriteFileAtomic(dst, ReadFileToString(src));
  }
  if (mask.width != width || mask.height != height) {
    RELIGHT_USER_ERROR() << "'" << folder << "/mask.png' does not match the photos' size";
  }

  // One far pinhole camera reproducing the orthographic ball.
  const double distance = options.camera_distance;
  const double focal = scene.radius_px * std::sqrt(distance * distance - 1.0);  // tangent rays graze the unit ball
  Reconstruction model;
  model.cameras[1] = Camera::Pinhole(1, width, height, focal, focal, scene.center_px.x(), scene.center_px.y());
  Eigen::Matrix3d cam_from_world;
  cam_from_world << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  for (size_t i = 0; i < names.size(); ++i) {
    ImageRecord im;
    im.image_id = static_cast<uint32_t>(i + 1);
    im.camera_id = 1;
    im.name = names[i];
    im.SetPose(cam_from_world, Eigen::Vector3d(0, -distance, 0));
    model.images[im.image_id] = im;
  }
  model.WriteText(gt);
  WriteMeshPly(JoinPath(gt, "mesh.ply"), MakeOctasphere(options.sphere_subdivisions));

  Json lights = Json::array();
  for (size_t i = 0; i < names.size(); ++i) {
    KnownDirectionalLight l;
    l.photo = names[i];
    l.direction_world = DiligentToWorld(dirs[i]).normalized();
    l.intensity_rgb = intensities[i];
    scene.lights.push_back(l);
    lights.push_back({{"name", l.photo},
                      {"direction_world", {l.direction_world.x(), l.direction_world.y(), l.direction_world.z()}},
                      {"intensity_rgb", {l.intensity_rgb.x(), l.intensity_rgb.y(), l.intensity_rgb.z()}}});
  }
  WriteJsonAtomic(JoinPath(gt, "lights.json"),
                  Json{{"format", "relight-directional-lights"},
                       {"version", 1},
                       {"source", "DiLiGenT (Shi et al. 2016), converted to the pipeline's world frame"},
                       {"ball_center_px", {scene.center_px.x(), scene.center_px.y()}},
                       {"ball_radius_px", scene.radius_px},
                       {"lights", lights}});
  return scene;
}

std::vector<KnownDirectionalLight> ReadDirectionalLights(const std::string& path) {
  const Json j = ReadJsonFile(path);
  std::vector<KnownDirectionalLight> out;
  try {
    for (const auto& l : j.at("lights")) {
      KnownDirectionalLight d;
      d.photo = l.at("name");
      const auto dir = l.at("direction_world").get<std::vector<double>>();
      const auto rgb = l.at("intensity_rgb").get<std::vector<double>>();
      d.direction_world = Eigen::Vector3d(dir[0], dir[1], dir[2]).normalized();
      d.intensity_rgb = Eigen::Vector3d(rgb[0], rgb[1], rgb[2]);
      out.push_back(d);
    }
  } catch (const Json::exception& e) {
    RELIGHT_USER_ERROR() << "'" << path << "' is malformed (" << e.what() << ")";
  }
  return out;
}

}  // namespace relight
