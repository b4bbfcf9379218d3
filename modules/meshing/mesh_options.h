// Options of the `mesh` stage: the object's triangle mesh in the world frame,
// cleaned, cropped and resampled to a per-vertex budget (docs/FORMATS.md).
#pragma once

#include <string>
#include <vector>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kMeshStage{
    "mesh", "Mesh clean-up (CGAL): largest parts, holes, cropping, remeshing to a vertex budget, outward normals", 4};

struct MeshOptions {
  std::string source = "mvs";        // mvs: <mvs>/meshed.ply; file: mesh.file; ground_truth: <ingest>/ground_truth.
  std::string file;                  // User mesh (PLY/OBJ/OFF) for source=file.
  std::string file_frame = "world";  // Frame of mesh.file: world (sfm output) or colmap (before sfm's rotation).
  int target_vertices = 50000;       // Vertex budget of the output (the method works per vertex); 0 keeps.
  std::string resample = "remesh";   // remesh: isotropic remeshing (uniform triangles); decimate: edge collapse only.
  int max_components = 1;            // Keep at most this many connected components, best supported first.
  double min_component_fraction = 0.05;  // Drop components with less than this fraction of the best one's score.
  int max_hole_edges = 500;              // Fill holes bounded by at most this many edges ...
  double max_hole_fraction = 0.1;        // ... and no wider than this fraction of the bounding-box diagonal.
  bool auto_crop = true;                 // Crop to the region seen by the registered cameras (sparse points).
  double crop_percentile = 2.0;          // Robust extent of the sparse points: percentiles [p, 100-p] per axis ...
  double crop_margin = 0.15;             // ... grown on each side by this fraction of its largest side.
  int crop_min_views = 2;                // A kept face lies in front of at least this many camera frusta.
  double max_point_distance =
      0.02;  // Drop faces farther than this (fraction of the points' box diagonal) from every point.
  std::vector<double> crop_box;     // Optional world box [xmin, ymin, zmin, xmax, ymax, zmax]; empty: none.
  bool clean_ground_truth = false;  // Also clean/resample the ground-truth mesh (default: pass it through).
  int remesh_iterations = 3;        // Isotropic remeshing iterations per pass.

  void Declare(OptionTable* t) {
    t->Add("source", &source,
           "mvs: the dense reconstruction (<mvs>/meshed.ply); file: mesh.file; ground_truth: "
           "<ingest>/ground_truth/mesh.ply (+ occluders.ply), passed through.")
        .Choices({"mvs", "file", "ground_truth"});
    t->Add("file", &file, "Mesh file (PLY/OBJ/OFF) for mesh.source=file.").InputFile().OnlyWhen("source", {"file"});
    t->Add("file_frame", &file_frame,
           "Frame of mesh.file: world (the sfm stage's output frame) or colmap (COLMAP's frame before the "
           "sfm stage's up rotation; sfm_summary.json world_from_colmap is applied).")
        .Choices({"world", "colmap"})
        .OnlyWhen("source", {"file"});
    t->Add("target_vertices", &target_vertices,
           "Vertex budget of the output mesh (the inverse rendering works per vertex; 30K-100K is typical; "
           "more costs visibility and solve time); 0 keeps the input resolution.")
        .Min(0);
    t->Add("resample", &resample,
           "remesh: isotropic remeshing to uniform triangles (best for per-vertex reflectance); decimate: "
           "edge collapse only (keeps detail where the input has it).")
        .Choices({"remesh", "decimate"});
    t->Add("max_components", &max_components,
           "Keep at most this many connected components: those with the most fused points within "
           "mesh.max_point_distance first (largest area first without fused points).")
        .Min(1);
    t->Add("min_component_fraction", &min_component_fraction,
           "Drop kept components scoring less than this fraction of the best one (fused points near it, else area).")
        .Range(0, 1)
        .Advanced();
    t->Add("max_hole_edges", &max_hole_edges, "Fill holes bounded by at most this many edges (0: fill none).").Min(0);
    t->Add("max_hole_fraction", &max_hole_fraction,
           "Fill only holes no wider than this fraction of the mesh's bounding-box diagonal.")
        .Range(0, 1)
        .Advanced();
    t->Add("auto_crop", &auto_crop,
           "Crop to the region seen by the registered cameras: the robust box of the sparse points, and faces "
           "in front of at least mesh.crop_min_views cameras.");
    t->Add("crop_percentile", &crop_percentile, "Robust box: per-axis percentiles [p, 100-p] of the sparse points.")
        .Range(0, 49)
        .Advanced()
        .OnlyWhen("auto_crop", {"true"});
    t->Add("crop_margin", &crop_margin, "Robust box grown on each side by this fraction of its largest side.")
        .Min(0)
        .Advanced()
        .OnlyWhen("auto_crop", {"true"});
    t->Add("crop_min_views", &crop_min_views, "A kept face lies inside at least this many camera frusta.")
        .Min(0)
        .Advanced()
        .OnlyWhen("auto_crop", {"true"});
    t->Add("max_point_distance", &max_point_distance,
           "Auto crop: drop faces farther than this fraction of the point cloud's bounding-box diagonal from every "
           "point of <mvs>/fused.ply (else the sparse points): a Poisson surface's closing bubble away from the "
           "data; 0 disables.")
        .Range(0, 1)
        .Advanced()
        .OnlyWhen("auto_crop", {"true"});
    t->Add("crop_box", &crop_box, "Optional world-frame box [xmin, ymin, zmin, xmax, ymax, zmax]; faces outside go.");
    t->Add("clean_ground_truth", &clean_ground_truth,
           "Clean and resample the ground-truth mesh too (default: pass it through unchanged).")
        .Advanced();
    t->Add("remesh_iterations", &remesh_iterations, "Isotropic remeshing iterations per pass.")
        .Range(1, 20)
        .Advanced()
        .OnlyWhen("resample", {"remesh"});
  }
  void Check() const {
    if (source == "file" && file.empty()) {
      RELIGHT_USER_ERROR() << "mesh.source is 'file' but mesh.file is empty: set mesh.file to a PLY/OBJ/OFF mesh";
    }
    if (!crop_box.empty()) {
      if (crop_box.size() != 6) {
        RELIGHT_USER_ERROR() << "mesh.crop_box has " << crop_box.size()
                             << " numbers; give 6: [xmin, ymin, zmin, xmax, ymax, zmax]";
      }
      for (int k = 0; k < 3; ++k) {
        if (!(crop_box[k] < crop_box[k + 3])) {
          RELIGHT_USER_ERROR() << "mesh.crop_box: min "
                               << "xyz"[k] << " (" << crop_box[k] << ") must be below max (" << crop_box[k + 3] << ")";
        }
      }
    }
  }
};

}  // namespace relight
