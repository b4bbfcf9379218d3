// The `visibility` stage (Haber et al. 2009, §4, eq. 2): for every mesh vertex,
// which part of the upper hemisphere of its local frame (sphere/frame.h) is
// blocked by the scene (the mesh and any occluders), on a hemi-octahedral map
// of N×N texels, each the fraction of its supersampled rays that escape. The
// map is stored as the sparse non-standard Haar coefficients that keep a given
// share of its energy (`visibility.bin`, docs/FORMATS.md).
#pragma once

#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/raycaster.h"
#include "visibility/visibility_options.h"
#include "wavelet/haar.h"

namespace relight {

// Per-vertex visibility in the Haar basis.
struct VisibilityData {
  int resolution = 0;                         // N of the N×N hemi-octahedral maps
  int supersampling = 0;
  float keep_energy = 1.0f;
  std::vector<SparseCoefficients> per_vertex;  // indices per wavelet/haar.h

  // The dense N×N visibility map (texel values) of a vertex.
  std::vector<float> DenseMap(size_t vertex) const;
};

inline constexpr char kVisibilityMagic[8] = {'R', 'L', 'V', 'I', 'S', 0, 0, 0};
inline constexpr uint32_t kVisibilityVersion = 1;

void WriteVisibility(const std::string& path, const VisibilityData& data);
// Throws UserError naming the file when it is damaged or of another version.
VisibilityData ReadVisibility(const std::string& path);

// Local directions of the supersampled rays of every texel, texel-major:
// entry (j*N + i)*ss² + k is sample k of texel (i, j).
std::vector<Eigen::Vector3f> HemiOctSampleDirections(int resolution, int supersampling);

// Bakes the dense visibility maps (texel fractions in [0,1]) of `vertices`
// (indices into `mesh`), `resolution`² floats each, into `maps`.
void BakeVisibilityMaps(const TriangleMesh& mesh, const RayCaster& caster, const std::vector<uint32_t>& vertices,
                        const VisibilityOptions& options, std::vector<float>* maps);

// The sparse Haar form (as the stage stores it: options.keep_energy) of dense maps from BakeVisibilityMaps,
// `count` maps of options.resolution² texels.
std::vector<SparseCoefficients> CompressVisibilityMaps(const std::vector<float>& maps, size_t count,
                                                       const VisibilityOptions& options);

// Every vertex of `mesh` baked against `caster` and compressed: the stage's visibility.bin content, in memory
// (tests, benchmarks and tools that need the maps without the stage).
VisibilityData ComputeVisibility(const TriangleMesh& mesh, const RayCaster& caster, const VisibilityOptions& options);

struct VisibilitySummary {
  size_t vertices = 0;
  double mean_open_fraction = 0;    // mean over vertices of the unblocked share of the hemisphere
  double mean_coefficients = 0;     // kept Haar coefficients per vertex
  double rays_per_second = 0;
  int reused_chunks = 0;
  double seconds = 0;

  // One line for the log.
  std::string BriefReport() const;
};

// Runs the stage: <mesh>/mesh.ply (+ occluders.ply) -> visibility.bin, visibility_summary.json.
struct VisibilityInputs {
  std::string mesh_dir;  // the mesh stage's folder
};
VisibilitySummary RunVisibility(const VisibilityOptions& options, const VisibilityInputs& inputs,
                                const std::string& output_dir);

}  // namespace relight
