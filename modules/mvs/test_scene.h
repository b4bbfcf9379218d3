// Synthetic stereo scenes with known depth, for the mvs tests and benchmark
// (not part of the library): a mesh with a procedural solid texture
// (3-octave value noise, so every surface patch has texture), Lambertian
// shading under a fixed directional light (view-independent, as stereo
// assumes), ray cast with Embree at 2×2 samples per pixel; ground-truth depth
// is the camera z of the pixel-centre ray's hit. Sparse points are surface
// samples with the tracks of the views that see them, so source selection
// and depth ranges work as on a real SfM model.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/reconstruction.h"
#include "image/image.h"

namespace relight::mvs_test {

// A rendered scene.
struct TestScene {
  TriangleMesh mesh;           // ground-truth surface, world frame
  Reconstruction model;        // one PINHOLE camera, images with true poses, sparse points with tracks
  std::vector<Image> images;   // RGB renders, sRGB-encoded [0, 1], in model image order
  std::vector<Image> depths;   // camera z of the pixel-centre hits, 0 = background, in model image order
  double bbox_diagonal = 0;    // of the mesh
};

// Sphere of radius ~1 at the origin with smooth radial bumps (±0.2): an icosphere with `subdivisions` levels.
TriangleMesh MakeBumpySphere(int subdivisions);
// A square of side `size` in the plane z = `z`, facing -z, split into 2 triangles.
TriangleMesh MakeSquare(double size, double z);

// Cameras at `centers_world` looking at `target` with world +Z up.
std::vector<ImageRecord> LookAtCameras(const std::vector<Eigen::Vector3d>& centers_world,
                                       const Eigen::Vector3d& target);
// Two rings around the origin at `distance`: `per_ring` views at +35° and at -20° elevation (offset by half a step).
std::vector<Eigen::Vector3d> TwoRingCenters(int per_ring, double distance);
// Images 1..n of camera 1, named <prefix><i>.png, at `centers`, all looking along +z (identity rotation).
std::vector<ImageRecord> CamerasLookingAlongZ(const std::vector<Eigen::Vector3d>& centers, const std::string& prefix);

// Renders `mesh` into every camera (shared PINHOLE `camera`) and builds the sparse model from `num_points`
// visible surface samples.
TestScene RenderScene(const TriangleMesh& mesh, const Camera& camera, const std::vector<ImageRecord>& poses,
                      int num_points, uint64_t seed);

// Writes `<sfm_dir>/dense/images/*.png` and `<sfm_dir>/dense/sparse/*.bin`, the layout of colmap image_undistorter.
void WriteSfmWorkspace(const TestScene& scene, const std::string& sfm_dir);

// Writes the scene's ground truth as the synthesize stage does (docs/FORMATS.md): cameras.txt, images.txt,
// points3D.txt, mesh.ply and depth/<stem>.exr.
void WriteGroundTruth(const TestScene& scene, const std::string& dir);

// Grey version of a render at its size (Rec. 601 luma), as the mvs stage loads it.
Image ToGray(const Image& rgb);

}  // namespace relight::mvs_test
