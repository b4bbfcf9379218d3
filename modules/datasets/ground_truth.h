// The one reader of a ground-truth folder (docs/FORMATS.md, "Ground truth
// folder (`ground_truth/`)"): written by `synthesize` and the importers
// (datasets/diligent.h), carried along by `ingest` as <ingest>/ground_truth/.
// Layout (every file optional but the cameras):
//   cameras.txt, images.txt (or .bin)   COLMAP model of the photos
//   mesh.ply, materials.json            the object and its materials
//   occluders.ply                       other shadow-casting geometry
//   lighting.json, envmaps/             per photo: its map, exposure, white balance
//   depth/<stem>.exr, masks/<stem>.png  per photo: true depth and object mask
//   lights.json                         per photo: a directional light (imported data sets)
//   relight/index.json, relight/...     held-out views under held-out maps
// Stage libraries never include this: the stage mains (pipeline/stages/)
// and `evaluate` read the truth and hand the stages typed inputs.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "core/json.h"
#include "geometry/reconstruction.h"

namespace relight {

// One photo's entry of lighting.json.
struct TruePhotoLighting {
  std::string name;            // photo file name
  std::string envmap_latlong;  // path of the map as rendered (scene radiance, before exposure and white balance)
  double exposure = 1;
  Eigen::Vector3d white_balance = Eigen::Vector3d::Ones();
  Json entry;  // the whole entry (environment, noise, ...)
};

// relight/index.json: held-out views under held-out maps; paths resolved against relight/.
struct TrueHeldout {
  struct Envmap {
    std::string name;
    std::string latlong;  // path
    Json details;         // the envmap_details entry (source, sun_dir_world, ...)
  };
  struct Render {
    std::string view, envmap;
    Json entry;  // {"view", "envmap", "image", "mask", "depth"} as written (relative to relight/)
  };
  std::string dir;    // <ground truth>/relight (the held-out cameras' COLMAP model)
  std::string index;  // path of index.json
  std::vector<Envmap> envmaps;
  std::vector<Render> renders;

  // The envmap named `name`; nullptr when there is none.
  const Envmap* FindEnvmap(const std::string& name) const;
};

class GroundTruth {
 public:
  // The folder `dir`, whether or not it exists (its paths name the files in messages).
  static GroundTruth At(const std::string& dir) { return GroundTruth(dir); }
  // The folder `dir`; nullopt when `dir` is empty or not a folder.
  static std::optional<GroundTruth> Open(const std::string& dir);
  // Where `ingest` carries the folder: <ingest_dir>/ground_truth, whether or not it exists; an empty
  // `ingest_dir` gives an empty folder name, which never exists.
  static GroundTruth OfIngest(const std::string& ingest_dir);

  // Whether the folder exists.
  bool Exists() const;
  const std::string& dir() const { return dir_; }

  // The photos' cameras: a COLMAP model folder (the ground truth's own).
  bool HasCameras() const;
  std::string CamerasFile() const;  // images.txt, for messages
  Reconstruction ReadCameras() const;
  std::string MeshPath() const;
  bool HasMesh() const;
  std::string OccludersPath() const;
  bool HasOccluders() const;
  std::string MaterialsPath() const;
  // materials.json; throws UserError naming it when missing or malformed.
  ReflectanceModel ReadMaterials() const;
  std::string LightingPath() const;
  bool HasLighting() const;
  // lighting.json's photos; throws UserError naming it when missing or malformed.
  std::vector<TruePhotoLighting> ReadLighting() const;
  // Per photo `stem` (file name without extension): true depth and object mask.
  std::string DepthPath(const std::string& stem) const;
  std::string MaskPath(const std::string& stem) const;
  // The known directional light per photo (imported photometric-stereo sets; datasets/light_evaluation.h).
  std::string LightsPath() const;
  bool HasLights() const;
  // Held-out views (relight/index.json).
  std::string HeldoutIndexPath() const;
  bool HasHeldout() const;
  // relight/index.json; throws UserError naming it when missing, malformed, or when a render names a map that
  // envmap_details does not list.
  TrueHeldout ReadHeldout() const;
  // relight/cameras.txt, images.txt: the held-out views (image names = view names).
  Reconstruction ReadHeldoutCameras() const;

 private:
  // Whether `path` (one of the folder's) is a file.
  bool Holds(const std::string& path) const;
  explicit GroundTruth(std::string dir) : dir_(std::move(dir)) {}
  std::string dir_;
};

}  // namespace relight
