#include "datasets/ground_truth.h"

#include <filesystem>

#include "core/error.h"
#include "core/fs.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

// A field of a JSON file's entry; throws UserError naming the file.
template <typename T>
T Field(const Json& entry, const char* key, const std::string& file) {
  try {
    return entry.at(key).get<T>();
  } catch (const Json::exception& e) {
    RELIGHT_USER_ERROR() << "'" << file << "': an entry has no valid '" << key << "' (" << e.what()
                         << "); regenerate the ground truth";
  }
}

}  // namespace

const TrueHeldout::Envmap* TrueHeldout::FindEnvmap(const std::string& name) const {
  for (const auto& e : envmaps)
    if (e.name == name) return &e;
  return nullptr;
}

std::optional<GroundTruth> GroundTruth::Open(const std::string& dir) {
  GroundTruth truth(dir);
  if (!truth.Exists()) return std::nullopt;
  return truth;
}

GroundTruth GroundTruth::OfIngest(const std::string& ingest_dir) {
  return GroundTruth(ingest_dir.empty() ? "" : JoinPath(ingest_dir, "ground_truth"));
}

bool GroundTruth::Exists() const { return !dir_.empty() && fs::is_directory(dir_); }

bool GroundTruth::Holds(const std::string& path) const { return Exists() && fs::is_regular_file(path); }

bool GroundTruth::HasCameras() const {
  return Exists() && (fs::exists(JoinPath(dir_, "images.txt")) || fs::exists(JoinPath(dir_, "images.bin")));
}

std::string GroundTruth::CamerasFile() const { return JoinPath(dir_, "images.txt"); }

Reconstruction GroundTruth::ReadCameras() const { return Reconstruction::Read(dir_); }

std::string GroundTruth::MeshPath() const { return JoinPath(dir_, "mesh.ply"); }
bool GroundTruth::HasMesh() const { return Holds(MeshPath()); }
std::string GroundTruth::OccludersPath() const { return JoinPath(dir_, "occluders.ply"); }
bool GroundTruth::HasOccluders() const { return Holds(OccludersPath()); }
std::string GroundTruth::MaterialsPath() const { return JoinPath(dir_, "materials.json"); }
ReflectanceModel GroundTruth::ReadMaterials() const { return ReadReflectanceModel(MaterialsPath()); }
std::string GroundTruth::LightingPath() const { return JoinPath(dir_, "lighting.json"); }
bool GroundTruth::HasLighting() const { return Holds(LightingPath()); }

std::vector<TruePhotoLighting> GroundTruth::ReadLighting() const {
  const std::string path = LightingPath();
  const Json j = ReadJsonFile(path);
  if (!j.contains("photos") || !j.at("photos").is_array()) {
    RELIGHT_USER_ERROR() << "'" << path << "' has no \"photos\" list; regenerate the ground truth";
  }
  std::vector<TruePhotoLighting> photos;
  for (const auto& p : j.at("photos")) {
    TruePhotoLighting l;
    l.name = Field<std::string>(p, "name", path);
    l.envmap_latlong = JoinPath(dir_, Field<std::string>(p, "envmap_latlong", path));
    const auto wb = p.value("white_balance", std::vector<double>{1, 1, 1});
    if (wb.size() != 3) RELIGHT_USER_ERROR() << "'" << path << "': photo '" << l.name << "' has no RGB white_balance";
    l.exposure = p.value("exposure", 1.0);
    l.white_balance = Eigen::Vector3d(wb[0], wb[1], wb[2]);
    l.entry = p;
    photos.push_back(std::move(l));
  }
  return photos;
}

std::string GroundTruth::DepthPath(const std::string& stem) const { return JoinPath(dir_, "depth/" + stem + ".exr"); }
std::string GroundTruth::MaskPath(const std::string& stem) const { return JoinPath(dir_, "masks/" + stem + ".png"); }
std::string GroundTruth::LightsPath() const { return JoinPath(dir_, "lights.json"); }
bool GroundTruth::HasLights() const { return Holds(LightsPath()); }
std::string GroundTruth::HeldoutIndexPath() const { return JoinPath(JoinPath(dir_, "relight"), "index.json"); }
bool GroundTruth::HasHeldout() const { return Holds(HeldoutIndexPath()); }

TrueHeldout GroundTruth::ReadHeldout() const {
  TrueHeldout h;
  h.dir = JoinPath(dir_, "relight");
  h.index = HeldoutIndexPath();
  const Json index = ReadJsonFile(h.index);
  if (index.contains("envmap_details")) {
    for (const auto& d : index.at("envmap_details")) {
      TrueHeldout::Envmap e;
      e.name = Field<std::string>(d, "name", h.index);
      e.latlong = JoinPath(h.dir, Field<std::string>(d, "latlong", h.index));
      e.details = d;
      h.envmaps.push_back(std::move(e));
    }
  }
  if (!index.contains("renders") || !index.at("renders").is_array()) {
    RELIGHT_USER_ERROR() << "'" << h.index << "' has no \"renders\" list; regenerate the ground truth";
  }
  for (const auto& r : index.at("renders")) {
    TrueHeldout::Render render;
    render.view = Field<std::string>(r, "view", h.index);
    render.envmap = Field<std::string>(r, "envmap", h.index);
    render.entry = r;
    h.renders.push_back(std::move(render));
  }
  return h;
}

Reconstruction GroundTruth::ReadHeldoutCameras() const { return Reconstruction::Read(JoinPath(dir_, "relight")); }

}  // namespace relight
