// The `mesh` stage: the object's triangle mesh in the world frame with
// outward vertex normals, from the MVS surface, a user's mesh, or a known
// (true) mesh the stage's main gives (docs/FORMATS.md):
//   mesh.ply           object mesh: x y z nx ny nz (+ the ground truth's named vertex properties)
//   occluders.ply      other shadow-casting geometry (ground truth only)
//   mesh_summary.json  what the clean-up did (vertex counts, holes, components, cropping, orientation)
//
// Open meshes (a building's facade, a cropped Poisson surface) are oriented
// so that the faces the registered cameras see face them; closed ones by
// CGAL's volume orientation.
#pragma once

#include <string>

#include "geometry/reconstruction.h"
#include "meshing/mesh_cleanup.h"
#include "meshing/mesh_options.h"

namespace relight {

// Upstream folders of the stage; empty when not available.
struct MeshInputs {
  std::string sfm_dir;
  std::string mvs_dir;
  // A known mesh passed through uncleaned unless mesh.clean_ground_truth, and its occluders (may be empty):
  // the ground-truth source's files, which the stage's main resolves (the library reads no ground truth).
  std::string known_mesh;
  std::string known_occluders;
};

// Result of the stage.
struct MeshSummary {
  std::string source;  // mesh.source
  std::string input_path;
  size_t input_vertices = 0;
  size_t input_faces = 0;
  size_t faces_cropped_box = 0;       // outside the robust sparse-point box or mesh.crop_box
  size_t faces_cropped_views = 0;     // seen by fewer than mesh.crop_min_views cameras
  size_t faces_cropped_distance = 0;  // farther than mesh.max_point_distance from the points
  bool cleaned = false;               // false: ground truth passed through
  MeshCleanupSummary cleanup;
  std::string orientation_method;    // volume | cameras | centroid | as given
  bool orientation_flipped = false;  // by the camera or centroid vote (open meshes)
  size_t boundary_edges = 0;
  int components = 0;
  bool manifold = false;
  size_t output_vertices = 0;
  size_t output_faces = 0;
  size_t occluder_faces = 0;
  double seconds = 0;

  std::string BriefReport() const;
};

// Runs the stage into `output_dir` (exists).
MeshSummary RunMesh(const MeshOptions& options, const MeshInputs& inputs, const std::string& output_dir);

// Crop region: faces whose centroid lies in `box` and in front of at least
// `min_views` cameras of `cameras` (when given) are kept.
struct CropRegion {
  bool use_box = false;
  Eigen::AlignedBox3d box;
  const Reconstruction* cameras = nullptr;  // registered cameras (not owned); nullptr: no view test
  int min_views = 0;
  const std::vector<Eigen::Vector3d>* points = nullptr;  // data points (not owned); nullptr: no distance test
  double max_distance = 0;                               // world units; a face's centroid must be this close
};
// Removes faces outside the region (vertices are compacted); counts removals.
// The distance test is conservative on a voxel grid of cell `max_distance`:
// faces whose centroid's cell and its 26 neighbours hold no point go.
TriangleMesh CropMesh(const TriangleMesh& mesh, const CropRegion& region, size_t* removed_by_box,
                      size_t* removed_by_views, size_t* removed_by_distance = nullptr);

// Robust box of a model's sparse points: per-axis percentiles [p, 100-p],
// grown on each side by `margin` × the box's largest side (on every axis, so
// a thin vertical extent dominated by ground points does not crop the object).
// Empty when the model has < 10 points.
Eigen::AlignedBox3d SparsePointBox(const Reconstruction& model, double percentile, double margin);

// Orients an open mesh so that the faces seen by the cameras face them (ray
// casting for visibility); without cameras, so that faces point away from the
// centroid on average. Returns true when the faces were flipped.
bool OrientOutward(const Reconstruction* cameras, TriangleMesh* mesh, std::string* method);

}  // namespace relight
