// Procedural solid textures for synthetic reflectance: 3D gradient noise
// (Perlin, "Improving Noise", SIGGRAPH 2002), fractal sums of it (fBm), and
// cellular noise (Worley, "A Cellular Texture Basis Function", SIGGRAPH 1996).
//
// Written by hand: about a hundred lines, seeded and deterministic on every
// platform; a library (libnoise) would add a dependency for this alone.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace relight {

// Seeded 3D gradient noise; values in about [-1, 1], zero at integer lattice points.
class GradientNoise {
 public:
  explicit GradientNoise(uint64_t seed);
  // Noise at `p` (one lattice cell per unit).
  double operator()(const Eigen::Vector3d& p) const;
  // Fractal sum of `octaves` octaves, frequency x2 and amplitude x`gain` per octave,
  // normalised by the total amplitude so the result stays in about [-1, 1].
  double Fractal(const Eigen::Vector3d& p, int octaves, double gain = 0.5) const;

 private:
  std::array<uint8_t, 512> perm_;
};

// The nearest and second-nearest feature points of seeded cellular noise.
struct CellSample {
  double distance1 = 0;  // to the nearest feature point (cell units)
  double distance2 = 0;  // to the second nearest
  uint64_t id1 = 0;      // hash of the nearest point's cell
  uint64_t id2 = 0;      // hash of the second nearest point's cell
};

// Seeded cellular noise: one feature point, uniformly placed, per unit cell.
CellSample CellularNoise(const Eigen::Vector3d& p, uint64_t seed);

}  // namespace relight
