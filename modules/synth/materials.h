// Spatially varying reflectance of synthetic scenes: built-in material sets
// (each material a non-negative blend of basis BRDFs, as in seed §5.2) and
// per-vertex blending weights from a solid texture, so that structure from
// motion finds features on the object and on the ground.
#pragma once

#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "geometry/mesh.h"

namespace relight {

// The first `num_materials` (1..4) of the built-in object materials: terracotta
// (Lambertian), blue glaze (Lambertian + Phong n = 50), ivory (Lambertian + GGX
// alpha 0.15) and brass (dark Lambertian + Phong n = 500). Basis lobes no chosen
// material uses are dropped.
ReflectanceModel BuiltinObjectMaterials(int num_materials);
// Three Lambertian materials of the ground and blockers: pale stone, dark stone, sand.
ReflectanceModel BuiltinGroundMaterials();
// Three Lambertian primaries (albedo 0.8 in one channel each): with the "mosaic"
// pattern, a vertex's weights are its colour.
ReflectanceModel BuiltinPrimaryMaterials();

// How per-vertex weights are drawn.
struct WeightPattern {
  std::string kind = "noise";  // "noise" (softmax of fractal noise fields), "voronoi" (cells), "mosaic" (colour
                               // per cell plus fractal detail, three primary materials), "single" (material 0)
  double frequency = 5.0;      // pattern cycles per scene unit, coarsest octave / cell density
  int octaves = 4;             // fractal octaves ("noise")
  double sharpness = 40.0;     // softmax gain: larger gives crisper region borders
  uint64_t seed = 1;
};

// Sets properties w0 … w{M-1} (non-negative, summing to 1 per vertex) from the
// pattern evaluated at the vertex positions, and albedo_r/g/b, the diffuse
// albedo sum_m w_m c_m,lambertian. Throws UserError for an unknown pattern kind.
void AssignMaterialWeights(const ReflectanceModel& model, const WeightPattern& pattern, TriangleMesh* mesh);

// Removes basis lobes that no material uses (all-zero coefficients).
ReflectanceModel PruneUnusedLobes(const ReflectanceModel& model);

}  // namespace relight
