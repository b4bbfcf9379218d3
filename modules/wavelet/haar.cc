#include "wavelet/haar.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <numeric>
#include <type_traits>

#include "core/error.h"

namespace relight {

int Log2(int n) {
  RELIGHT_CHECK(n > 0 && (n & (n - 1)) == 0) << n << " is not a power of two";
  int l = 0;
  while ((1 << l) < n) ++l;
  return l;
}

HaarNode DecodeHaarIndex(uint32_t index, int n) {
  const int r = int(index / uint32_t(n)), c = int(index % uint32_t(n));
  HaarNode node;
  if (r == 0 && c == 0) return node;
  const int m = std::max(r, c);
  int l = 0;
  while ((2 << l) <= m) ++l;
  const int s = 1 << l;
  node.level = l;
  if (r < s) {
    node.type = HaarType::kDx;
    node.a = c - s;
    node.b = r;
  } else if (c < s) {
    node.type = HaarType::kDy;
    node.a = c;
    node.b = r - s;
  } else {
    node.type = HaarType::kDxy;
    node.a = c - s;
    node.b = r - s;
  }
  return node;
}

uint32_t HaarIndex(HaarType type, int level, int a, int b, int n) {
  const int s = 1 << level;
  switch (type) {
    case HaarType::kDx:
      return uint32_t(b) * n + s + a;
    case HaarType::kDy:
      return uint32_t(s + b) * n + a;
    case HaarType::kDxy:
      return uint32_t(s + b) * n + s + a;
    case HaarType::kScaling:
      break;
  }
  return 0;
}

template <typename T>
void HaarForward(const T* pixels, int n, T* coeffs) {
  Log2(n);
  if (coeffs != pixels) std::copy(pixels, pixels + size_t(n) * n, coeffs);
  thread_local std::vector<T> tmp;
  tmp.resize(size_t(n) * n);
  for (int size = n; size > 1; size /= 2) {
    const int half = size / 2;
    for (int b = 0; b < half; ++b) {
      const T* r0 = coeffs + size_t(2 * b) * n;
      const T* r1 = r0 + n;
      T* avg = tmp.data() + size_t(b) * size;
      T* dy = tmp.data() + size_t(half + b) * size;
      for (int a = 0; a < half; ++a) {
        const T p00 = r0[2 * a], p01 = r0[2 * a + 1], p10 = r1[2 * a], p11 = r1[2 * a + 1];
        avg[a] = T(0.5) * (p00 + p01 + p10 + p11);
        avg[half + a] = T(0.5) * (p00 - p01 + p10 - p11);
        dy[a] = T(0.5) * (p00 + p01 - p10 - p11);
        dy[half + a] = T(0.5) * (p00 - p01 - p10 + p11);
      }
    }
    for (int r = 0; r < size; ++r)
      std::copy(tmp.data() + size_t(r) * size, tmp.data() + size_t(r + 1) * size, coeffs + size_t(r) * n);
  }
}

template <typename T>
void HaarInverse(const T* coeffs, int n, T* pixels) {
  Log2(n);
  if (coeffs != pixels) std::copy(coeffs, coeffs + size_t(n) * n, pixels);
  thread_local std::vector<T> tmp;
  tmp.resize(size_t(n) * n);
  for (int size = 2; size <= n; size *= 2) {
    const int half = size / 2;
    for (int b = 0; b < half; ++b) {
      const T* avg = pixels + size_t(b) * n;
      const T* dy = pixels + size_t(half + b) * n;
      T* r0 = tmp.data() + size_t(2 * b) * size;
      T* r1 = r0 + size;
      for (int a = 0; a < half; ++a) {
        const T m = avg[a], x = avg[half + a], y = dy[a], xy = dy[half + a];
        r0[2 * a] = T(0.5) * (m + x + y + xy);
        r0[2 * a + 1] = T(0.5) * (m - x + y - xy);
        r1[2 * a] = T(0.5) * (m + x - y - xy);
        r1[2 * a + 1] = T(0.5) * (m - x - y + xy);
      }
    }
    for (int r = 0; r < size; ++r)
      std::copy(tmp.data() + size_t(r) * size, tmp.data() + size_t(r + 1) * size, pixels + size_t(r) * n);
  }
}

template <typename T>
double BasicSparseCoefficients<T>::Energy() const {
  double e = 0;
  for (const T& v : value) e += double(v) * double(v);
  return e;
}

template <typename T>
template <typename U>
void BasicSparseCoefficients<T>::ToDense(U* dense) const {
  std::fill(dense, dense + size_t(n) * n, U(0));
  for (size_t k = 0; k < index.size(); ++k) dense[index[k]] = U(value[k]);
}

template <typename T>
BasicSparseCoefficients<T> SparseFromDense(const T* coeffs, int n, double threshold) {
  BasicSparseCoefficients<T> out;
  out.n = n;
  for (uint32_t k = 0; k < uint32_t(n) * n; ++k) {
    if (coeffs[k] != T(0) && std::abs(double(coeffs[k])) > threshold) {
      out.index.push_back(k);
      out.value.push_back(coeffs[k]);
    }
  }
  return out;
}

namespace {
// Float coefficients ordered by decreasing magnitude, ties by lower index, as one integer key each: the bits of a
// non-negative float order as its value, so the complement of |c|'s bits above the index sorts ascending in that
// order (a plain integer sort, several times faster than comparing through the coefficients).
std::vector<uint64_t> MagnitudeKeys(const float* coeffs, size_t total) {
  std::vector<uint64_t> keys(total);
  for (size_t k = 0; k < total; ++k) {
    uint32_t bits;
    const float magnitude = std::abs(coeffs[k]);
    std::memcpy(&bits, &magnitude, sizeof bits);
    keys[k] = (uint64_t(~bits) << 32) | uint64_t(k);
  }
  return keys;
}
}  // namespace

template <typename T>
std::vector<uint32_t> IndicesByMagnitude(const T* coeffs, int n) {
  std::vector<uint32_t> order(size_t(n) * n);
  if constexpr (std::is_same_v<T, float>) {
    std::vector<uint64_t> keys = MagnitudeKeys(coeffs, order.size());
    std::sort(keys.begin(), keys.end());
    for (size_t k = 0; k < keys.size(); ++k) order[k] = static_cast<uint32_t>(keys[k]);
    return order;
  }
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t x, uint32_t y) { return std::abs(coeffs[x]) > std::abs(coeffs[y]); });
  return order;
}

namespace {
template <typename T>
BasicSparseCoefficients<T> Gather(const T* coeffs, int n, std::vector<uint32_t> kept) {
  std::sort(kept.begin(), kept.end());
  BasicSparseCoefficients<T> out;
  out.n = n;
  for (uint32_t k : kept) {
    if (coeffs[k] == T(0)) continue;
    out.index.push_back(k);
    out.value.push_back(coeffs[k]);
  }
  return out;
}
}  // namespace

template <typename T>
BasicSparseCoefficients<T> KeepLargest(const T* coeffs, int n, size_t k) {
  const size_t total = size_t(n) * n;
  k = std::min(k, total);
  if constexpr (std::is_same_v<T, float>) {
    std::vector<uint64_t> keys = MagnitudeKeys(coeffs, total);
    std::nth_element(keys.begin(), keys.begin() + k, keys.end());
    std::vector<uint32_t> kept(k);
    for (size_t q = 0; q < k; ++q) kept[q] = static_cast<uint32_t>(keys[q]);
    return Gather(coeffs, n, std::move(kept));
  }
  std::vector<uint32_t> order(total);
  std::iota(order.begin(), order.end(), 0u);
  auto larger = [&](uint32_t x, uint32_t y) {
    const T ax = std::abs(coeffs[x]), ay = std::abs(coeffs[y]);
    return ax > ay || (ax == ay && x < y);
  };
  std::nth_element(order.begin(), order.begin() + k, order.end(), larger);
  order.resize(k);
  return Gather(coeffs, n, std::move(order));
}

template <typename T>
BasicSparseCoefficients<T> KeepEnergy(const T* coeffs, int n, double fraction) {
  RELIGHT_CHECK(fraction > 0 && fraction <= 1) << "energy fraction " << fraction;
  const std::vector<uint32_t> order = IndicesByMagnitude(coeffs, n);
  double total = 0;
  for (uint32_t k : order) total += double(coeffs[k]) * double(coeffs[k]);
  std::vector<uint32_t> kept;
  double energy = 0;
  for (uint32_t k : order) {
    if (energy >= fraction * total) break;
    energy += double(coeffs[k]) * double(coeffs[k]);
    kept.push_back(k);
  }
  return Gather(coeffs, n, std::move(kept));
}

namespace {
// EnergyTruncator's key: c² (its float bits) above the complemented index.
float KeyEnergy(uint64_t key) {
  const uint32_t bits = static_cast<uint32_t>(key >> 16);
  float e;
  std::memcpy(&e, &bits, sizeof e);
  return e;
}
uint16_t KeyIndex(uint64_t key) { return static_cast<uint16_t>(0xFFFFu - (key & 0xFFFFu)); }
// The float exponent field of the energy: keys of a higher octave rank higher.
int KeyOctave(uint64_t key) { return static_cast<int>(key >> (16 + 23)) & 0xFF; }
}  // namespace

void EnergyTruncator::Run(const float* coeffs, int size, double fraction, int cap, std::vector<uint16_t>* index,
                          std::vector<float>* value) {
  RELIGHT_CHECK(size >= 0 && size <= 65536) << size << " coefficients: the kept indices are 16-bit";
  nz_.clear();
  double total = 0;
  for (int k = 0; k < size; ++k) {
    if (coeffs[k] == 0.0f) continue;
    const float e = coeffs[k] * coeffs[k];
    uint32_t bits;
    std::memcpy(&bits, &e, sizeof bits);
    nz_.push_back((uint64_t(bits) << 16) | (0xFFFFu - static_cast<uint32_t>(k)));
    total += e;
  }
  index->clear();
  value->clear();
  if (nz_.empty()) return;
  const size_t limit = static_cast<size_t>(std::max(0, cap));
  if (fraction >= 1.0 && nz_.size() <= limit) {  // everything
    index->reserve(nz_.size());
    value->reserve(nz_.size());
    for (uint64_t key : nz_) {
      index->push_back(KeyIndex(key));
      value->push_back(coeffs[KeyIndex(key)]);
    }
    return;
  }
  const std::greater<uint64_t> larger;
  const double target = fraction * total;
  // Invariant: [0, lo) are the lo highest ranked, with sum `acc` < target;
  // [lo, hi) the next ones; acc + their sum >= target (or hi = n).
  size_t keep = 0;
  if (target > 0) {
    // Energy and count per octave, then the octave where the sum from the top reaches the target.
    int top = 0, bottom = 255;  // octaves in use
    for (uint64_t key : nz_) {
      const int oct = KeyOctave(key);
      top = std::max(top, oct);
      bottom = std::min(bottom, oct);
      octave_energy_[oct] += KeyEnergy(key);
      ++octave_count_[oct];
    }
    int boundary = top;
    double above = 0;  // energy of the octaves above `boundary`
    size_t count_above = 0;
    while (boundary > bottom && above + octave_energy_[boundary] < target) {
      above += octave_energy_[boundary];
      count_above += octave_count_[boundary];
      --boundary;
    }
    // Keys above the boundary octave first, then the boundary's, then the rest.
    scratch_.resize(nz_.size());
    size_t hi_pos = 0, mid_pos = count_above, lo_pos = count_above + octave_count_[boundary];
    for (uint64_t key : nz_) {
      const int oct = KeyOctave(key);
      scratch_[oct > boundary ? hi_pos++ : oct == boundary ? mid_pos++ : lo_pos++] = key;
    }
    nz_.swap(scratch_);
    size_t lo = count_above, hi = count_above + octave_count_[boundary];
    for (int q = bottom; q <= top; ++q) {  // cleared for the next row
      octave_energy_[q] = 0;
      octave_count_[q] = 0;
    }
    double acc = above;
    while (hi - lo > 1) {
      const size_t mid = lo + (hi - lo) / 2;
      std::nth_element(nz_.begin() + lo, nz_.begin() + mid, nz_.begin() + hi, larger);
      double part = 0;
      for (size_t q = lo; q < mid; ++q) part += KeyEnergy(nz_[q]);
      if (acc + part >= target) {
        hi = mid;
      } else {
        acc += part;
        lo = mid;
      }
    }
    keep = hi;
  }
  if (keep > limit) {
    std::nth_element(nz_.begin(), nz_.begin() + limit, nz_.begin() + keep, larger);
    keep = limit;
  }
  kept_.assign(size, 0);
  for (size_t q = 0; q < keep; ++q) kept_[KeyIndex(nz_[q])] = 1;
  index->reserve(keep);
  value->reserve(keep);
  for (int k = 0; k < size; ++k) {
    if (!kept_[k]) continue;
    index->push_back(static_cast<uint16_t>(k));
    value->push_back(coeffs[k]);
  }
}

#define RELIGHT_INSTANTIATE_HAAR(T)                                              \
  template void HaarForward<T>(const T*, int, T*);                               \
  template void HaarInverse<T>(const T*, int, T*);                               \
  template struct BasicSparseCoefficients<T>;                                    \
  template void BasicSparseCoefficients<T>::ToDense<float>(float*) const;        \
  template void BasicSparseCoefficients<T>::ToDense<double>(double*) const;      \
  template BasicSparseCoefficients<T> SparseFromDense<T>(const T*, int, double); \
  template BasicSparseCoefficients<T> KeepLargest<T>(const T*, int, size_t);     \
  template BasicSparseCoefficients<T> KeepEnergy<T>(const T*, int, double);      \
  template std::vector<uint32_t> IndicesByMagnitude<T>(const T*, int);

RELIGHT_INSTANTIATE_HAAR(float)
RELIGHT_INSTANTIATE_HAAR(double)

}  // namespace relight
