// Leave-one-photo-out validation for collections without ground truth
// (docs/METRICS.md): for a scored photo i, the reflectance is solved from the
// other photos only (SolveInverse on the problem restricted to them), then
// only photo i's environment map is fitted with that reflectance held fixed,
// and the photo is rendered and scored. The reflectance never saw photo i, so
// the score measures how well the model predicts a photo it was not fitted
// to (the lighting of photo i can only come from photo i itself).
//
// Folds are grouped so that most of them start warm without ever having seen
// the photo they score: the scored photos are split into groups of at most a
// fifth of the collection (LeaveOutGroups); each group's reflectance is solved
// once from scratch without all of its photos (SolveWithout), and each photo of
// the group is then scored by a short fold started from that reflectance,
// with the group's other photos added back. No fold's start has seen its photo,
// so the score is as honest as a fold from scratch; a group of one photo is
// the plain fold from scratch. Starting from the full solve instead (which saw
// the photo) would score better than the truth: tools/loo_folds measures both.
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
  double photo_rmse = 0;               // confidence-weighted RMSE of the photo's observations under that fit
  double seconds = 0;
};

// Refits for photo `photo` (an index into problem->photos). `options` are the inverse stage's;
// `max_iterations` > 0 caps the outer iterations of the reflectance solve; `warm_start` (the full solve's
// reflectance, or null for a solve from scratch) is the fold's starting point. `problem` is restored on return.
LeaveOneOutFit LeaveOneOut(InverseProblem* problem, const InverseOptions& options, uint32_t photo, int max_iterations,
                           const ReflectanceState* warm_start = nullptr);

// The scored photos (`scored`, from SpreadPhotos) in groups left out together: at most
// max(1, num_photos / 5) photos per group, each group's photos spread over the list (round robin).
std::vector<std::vector<uint32_t>> LeaveOutGroups(const std::vector<uint32_t>& scored, uint32_t num_photos);

// The reflectance solved from scratch from every photo but the `left_out` ones (indices into
// problem->photos), with the inverse stage's `options`. `problem` is restored on return.
ReflectanceState SolveWithout(InverseProblem* problem, const InverseOptions& options,
                              const std::vector<uint32_t>& left_out);

// The reflectance state of a recovered model: `mesh` carries the weights w0… per vertex, `model` the
// materials; a lobe whose coefficient is 0 in every material counts as disabled (model selection dropped it).
// Throws UserError when a weight property is missing.
ReflectanceState ReflectanceStateOf(const TriangleMesh& mesh, const ReflectanceModel& model);

// The map of the single photo of `one_photo` (its observations renumbered to photo 0) fitted with
// `reflectance` held fixed (octahedral RGB, photo units, negative texels clamped to 0); `rmse`, when given,
// receives the confidence-weighted RMSE of the photo's observations under the fit.
Image FitLighting(const InverseProblem& one_photo, const InverseOptions& options, const ReflectanceState& reflectance,
                  double* rmse = nullptr);

// Up to `max_photos` photo indices evenly spread over [0, num_photos) (all when max_photos is 0 or larger).
std::vector<uint32_t> SpreadPhotos(uint32_t num_photos, int max_photos);

}  // namespace relight
