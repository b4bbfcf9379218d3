// Leave-one-photo-out validation for collections without ground truth
// (docs/METRICS.md): for a scored photo i, the reflectance is solved from the
// other photos only (SolveInverse on the problem restricted to them), then
// only photo i's environment map is fitted with that reflectance held fixed,
// and the photo is rendered and scored. The reflectance never saw photo i, so
// the score measures how well the model predicts a photo it was not fitted
// to (the lighting of photo i can only come from photo i itself).
#pragma once

#include <string>
#include <vector>

#include "image/image.h"
#include "solver/inverse.h"

namespace relight {

// Reads the inverse problem the stage solved: <mesh>/mesh.ply, <visibility>/visibility.bin,
// <observe>/observations.bin and photos.json. Throws UserError naming a missing or inconsistent file.
InverseProblem LoadInverseProblem(const std::string& mesh_dir, const std::string& visibility_dir,
                                  const std::string& observe_dir);

// The observations of the listed photos, their photo indices renumbered 0..k-1 in the given order.
ObservationSet RestrictObservations(const ObservationSet& observations, const std::vector<uint32_t>& photos);

// What the leave-one-out refit of one photo gives.
struct LeaveOneOutFit {
  uint32_t photo = 0;
  ReflectanceState reflectance;        // solved without the photo
  Image lighting_oct;                  // the photo's map fitted with that reflectance (octahedral RGB, photo units)
  InverseSummary reflectance_summary;  // of the solve without the photo
  double seconds = 0;
};

// Refits for photo `photo` (an index into problem->photos). `options` are the inverse stage's;
// `max_iterations` > 0 caps the outer iterations of the reflectance solve. `problem` is restored on return.
LeaveOneOutFit LeaveOneOut(InverseProblem* problem, const InverseOptions& options, uint32_t photo, int max_iterations);

// Up to `max_photos` photo indices evenly spread over [0, num_photos) (all when max_photos is 0 or larger).
std::vector<uint32_t> SpreadPhotos(uint32_t num_photos, int max_photos);

}  // namespace relight
