// The observation table exchanged between `observe`, `inverse` and `evaluate`
// (`observations.bin`, docs/FORMATS.md) and the photo list beside it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/camera.h"
#include "geometry/reconstruction.h"

namespace relight {

// One measurement y of the method: vertex `vertex` seen in photo `photo`.
struct Observation {
  uint32_t photo = 0;
  uint32_t vertex = 0;
  float rgb[3] = {0, 0, 0};         // linear radiance
  float confidence = 0;             // alpha_y in [0, 1]
  float view_local[3] = {0, 0, 1};  // unit direction to the camera, vertex's local frame (sphere/frame.h)
  uint32_t flags = 0;               // kObservationLowerBound, kObservationBoundChannels
  // Radius of what `rgb` averages, as a ratio to the nominal disc (footprint_scale ×
  // the vertex's area radius): the image-space disc's taps and the pyramid pixels'
  // own width, as the radius of the disc with the same second moment (>= 1 in
  // practice; 1 in files before version 4). FootprintKernelRadiusPx in observe.h.
  float kernel_scale = 1.0f;

  bool lower_bound() const;       // some channel is a lower bound
  bool lower_bound(int c) const;  // channel c is a lower bound
};

// The footprint held clipped pixels: `rgb` (the mean over all its pixels,
// clipped ones at their clipped value) is a lower bound of the true radiance,
// not an estimate, in the channels that clipped. Solvers enforce it only while
// their prediction falls below (a censored, one-sided residual).
inline constexpr uint32_t kObservationLowerBound = 1u;
// Which channels are bounds: bit 1 + c for channel c. With kObservationLowerBound
// and none of these bits, all three are (files written before per-channel flags,
// and footprints distrusted for another reason than over-exposure). The other
// channels of a flagged observation are ordinary measurements.
inline constexpr uint32_t kObservationBoundChannels = 7u << 1;
inline constexpr uint32_t ObservationBoundChannel(int c) { return 2u << c; }

inline bool Observation::lower_bound() const { return (flags & kObservationLowerBound) != 0; }
inline bool Observation::lower_bound(int c) const {
  return lower_bound() && ((flags & kObservationBoundChannels) == 0 || (flags & ObservationBoundChannel(c)) != 0);
}

// y − ŷ of channel c, censored for lower bounds: 0 where the prediction is at or above the bound.
inline float CensoredResidual(const Observation& ob, int c, float predicted) {
  const float e = ob.rgb[c] - predicted;
  return ob.lower_bound(c) && e < 0 ? 0.0f : e;
}

struct ObservationSet {
  uint32_t num_photos = 0;
  uint32_t num_vertices = 0;
  std::vector<Observation> records;  // sorted by photo, then vertex
};

// A photo as the observations index it.
struct ObservedPhoto {
  uint32_t index = 0;
  std::string name;          // image name in the SfM model (= ingest file name)
  std::string linear;        // linear image, relative to the linearize output folder
  Camera camera;             // intrinsics at the linear image's resolution
  ImageRecord pose;          // cam_from_world
  uint32_t observed_vertices = 0;
  double mean_confidence = 0;
};

inline constexpr char kObservationsMagic[8] = {'R', 'L', 'O', 'B', 'S', 0, 0, 0};
inline constexpr uint32_t kObservationsVersion = 4;  // 2 added `flags`, 3 per-channel bounds, 4 `kernel_scale`; 1 to 3 still read

// Writes atomically. Throws UserError naming the file on I/O failure.
void WriteObservations(const std::string& path, const ObservationSet& set);
// Reads and validates (magic, version, sizes, indices). Throws UserError naming the file.
ObservationSet ReadObservations(const std::string& path);

// photos.json beside observations.bin.
// `footprint_scale` is observe.footprint_scale: each observation averages the
// photo over a disc of that many times its vertex's area radius (the inverse
// stage's transport rows average over the same disc).
void WriteObservedPhotos(const std::string& path, const std::vector<ObservedPhoto>& photos,
                         double footprint_scale = 1.0);
std::vector<ObservedPhoto> ReadObservedPhotos(const std::string& path);
// The footprint scale recorded in photos.json (1, the default, for files that predate it).
double ReadObservedFootprintScale(const std::string& path);

}  // namespace relight
