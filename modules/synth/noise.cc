#include "synth/noise.h"

#include <cmath>

#include "render/rng.h"

namespace relight {
namespace {

double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
double Lerp(double t, double a, double b) { return a + t * (b - a); }
// Perlin's 12 edge gradients (and 4 repeats) selected by the low 4 bits of the hash.
double Grad(int hash, double x, double y, double z) {
  const int h = hash & 15;
  const double u = h < 8 ? x : y;
  const double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
  return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

}  // namespace

GradientNoise::GradientNoise(uint64_t seed) {
  std::array<uint8_t, 256> p;
  for (int i = 0; i < 256; ++i) p[i] = static_cast<uint8_t>(i);
  Pcg32 rng(seed, 0x401535);
  for (int i = 255; i > 0; --i) std::swap(p[i], p[rng.UniformInt(uint32_t(i + 1))]);
  for (int i = 0; i < 512; ++i) perm_[i] = p[i & 255];
}

double GradientNoise::operator()(const Eigen::Vector3d& q) const {
  const double fx = std::floor(q.x()), fy = std::floor(q.y()), fz = std::floor(q.z());
  const int X = static_cast<int>(static_cast<int64_t>(fx) & 255), Y = static_cast<int>(static_cast<int64_t>(fy) & 255),
            Z = static_cast<int>(static_cast<int64_t>(fz) & 255);
  const double x = q.x() - fx, y = q.y() - fy, z = q.z() - fz;
  const double u = Fade(x), v = Fade(y), w = Fade(z);
  const auto& p = perm_;
  const int A = p[X] + Y, AA = p[A] + Z, AB = p[A + 1] + Z;
  const int B = p[X + 1] + Y, BA = p[B] + Z, BB = p[B + 1] + Z;
  return Lerp(w,
              Lerp(v, Lerp(u, Grad(p[AA], x, y, z), Grad(p[BA], x - 1, y, z)),
                   Lerp(u, Grad(p[AB], x, y - 1, z), Grad(p[BB], x - 1, y - 1, z))),
              Lerp(v, Lerp(u, Grad(p[AA + 1], x, y, z - 1), Grad(p[BA + 1], x - 1, y, z - 1)),
                   Lerp(u, Grad(p[AB + 1], x, y - 1, z - 1), Grad(p[BB + 1], x - 1, y - 1, z - 1))));
}

double GradientNoise::Fractal(const Eigen::Vector3d& p, int octaves, double gain) const {
  double sum = 0, amplitude = 1, total = 0, frequency = 1;
  for (int o = 0; o < octaves; ++o) {
    // Offset each octave so the lattice zeros of different octaves do not line up.
    sum += amplitude * (*this)(p * frequency + Eigen::Vector3d(17.3 * o, -9.1 * o, 5.7 * o));
    total += amplitude;
    amplitude *= gain;
    frequency *= 2;
  }
  return total > 0 ? sum / total : 0.0;
}

CellSample CellularNoise(const Eigen::Vector3d& p, uint64_t seed) {
  const Eigen::Vector3d cell = p.array().floor();
  CellSample best;
  best.distance1 = best.distance2 = 1e300;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int64_t cx = int64_t(cell.x()) + dx, cy = int64_t(cell.y()) + dy, cz = int64_t(cell.z()) + dz;
        const uint64_t id = MixSeed(MixSeed(MixSeed(seed, uint64_t(cx)), uint64_t(cy)), uint64_t(cz));
        Pcg32 rng(id);
        const Eigen::Vector3d point(cx + rng.Uniform(), cy + rng.Uniform(), cz + rng.Uniform());
        const double d = (point - p).norm();
        if (d < best.distance1) {
          best.distance2 = best.distance1;
          best.id2 = best.id1;
          best.distance1 = d;
          best.id1 = id;
        } else if (d < best.distance2) {
          best.distance2 = d;
          best.id2 = id;
        }
      }
  return best;
}

}  // namespace relight
