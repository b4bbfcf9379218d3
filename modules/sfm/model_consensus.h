// Telling a right reconstruction from a wrong one without ground truth:
// incremental mapping started from different initial pairs, and the model
// most of the runs agree with.
//
// An incremental reconstruction inherits the errors of its first pair: a
// forward-moving or nearly planar first pair can place the whole collection
// wrongly while every reprojection error looks normal (one collection: 23 of
// 24 photos "registered" at a median rotation error of 18 degrees, 0.75 px).
// Two checks that need no ground truth: runs from different first pairs that
// place the shared photos the same way, and the model's agreement with every
// verified photo pair's own matches (does the epipolar geometry the model
// implies between the two photos explain them?). The matches a wrong model
// left out, or bent to fit, betray it: on one synthetic collection 82 of 83
// pairs agreed with the right model and only 54 of 76 with the wrong one;
// real photos have a few false pairs (5 of 44 on the Sacre-Coeur photos), so
// a model passes at 80 %. Planar pairs cannot tell (both of a plane's poses
// explain them), so the test fails wrong models, it does not prove right ones.
#pragma once

#include <Eigen/Core>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "geometry/reconstruction.h"

namespace relight {

// The essential matrix between two posed images: x_b^T E x_a = 0 for normalised rays x = (x/z, y/z, 1)
// of one world point in camera a and camera b.
Eigen::Matrix3d EssentialMatrix(const ImageRecord& a, const ImageRecord& b);
// Sampson distance of the ray pair (xa, xb) under E, in normalised units (times the focal length: pixels).
double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector3d& xa, const Eigen::Vector3d& xb);

// How two reconstructions of the same photos agree: camera centres aligned by a
// robust similarity, then, per photo in both (matched by image name), the angle
// between the two rotations.
struct ModelAgreement {
  int shared = 0;                  // photos in both models
  int within_tolerance = 0;        // shared photos whose rotations differ by at most the tolerance
  double median_rotation_deg = 0;  // over the shared photos
  std::vector<std::string> differing;  // shared photos beyond the tolerance
  // At least 3 shared photos and at least 80 % of them within the tolerance.
  bool agree() const { return shared >= 3 && within_tolerance >= 0.8 * shared; }
};
ModelAgreement CompareModels(const Reconstruction& a, const Reconstruction& b, double tolerance_deg);

// The matches of one verified photo pair, in pixels.
struct PairObservations {
  std::string name1, name2;  // image names as in the models
  std::vector<Eigen::Vector2d> points1, points2;
};

// How a model agrees with its photo pairs' matches.
struct TwoViewAgreement {
  int pairs = 0;     // pairs of the model's photos that were checked
  int agreeing = 0;  // of those, pairs at least half of whose matches the model's epipolar geometry explains
  std::map<std::string, std::pair<int, int>> per_photo;  // name -> (agreeing, checked) pairs it is part of
  double fraction() const { return pairs > 0 ? double(agreeing) / pairs : 0.0; }
};
// A match is explained within `max_error_px` (Sampson distance); pairs with fewer than `min_matches`
// matches are not checked.
TwoViewAgreement CheckTwoViewAgreement(const Reconstruction& model, const std::vector<PairObservations>& pairs,
                                       double max_error_px, int min_matches = 15);

// One incremental mapping run.
struct MapperRun {
  std::string init_pair;          // "a.jpg + b.jpg", or "COLMAP's choice"
  int num_models = 0;             // models the run produced
  int num_registered = 0;         // photos in its largest model
  std::set<std::string> split_off;  // photos only in its smaller models (SplitOffPhotos)
  double mean_reprojection_error_px = 0;
  double seconds = 0;
  std::vector<int> agrees_with;   // other runs whose largest model agrees with this one's
  TwoViewAgreement two_view;      // its largest model against the photo pairs' own rotations
  Reconstruction model;           // its largest model (empty: none)
};

// Photos of `models` (largest first, as COLMAP's mapper writes them) that only the smaller models hold: a part
// of the collection the largest model could not join. A smaller model COLMAP started from a first pair and
// abandoned, whose photos the largest model registered again, splits nothing off.
std::set<std::string> SplitOffPhotos(const std::vector<Reconstruction>& models);

// A model is consistent with its photo pairs when at least this fraction of the checked pairs agree.
inline constexpr double kMinTwoViewAgreement = 0.8;
// False when enough pairs were checked (3 or more) and too few agree.
inline bool Consistent(const TwoViewAgreement& t) { return t.pairs < 3 || t.fraction() >= kMinTwoViewAgreement; }

// The run to keep. Runs whose model is consistent with its photo pairs come
// first; among them the one that agrees with the most other runs (agreeing on
// at least half of the larger model's photos), then the one
// with the most photos, then the lowest reprojection error. -1 when no run has
// a model. Fills every run's `agrees_with` (runs need `two_view` filled).
int ChooseConsensusRun(std::vector<MapperRun>* runs, double tolerance_deg);

}  // namespace relight
