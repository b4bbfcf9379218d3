// 2D non-standard orthonormal Haar transform on an N x N grid (N a power of
// two) and sparse coefficient vectors with non-linear approximation.
//
// The all-frequency machinery of Haber et al. 2009, §4 (after Ng, Ramamoorthi,
// Hanrahan 2003/2004). Written by hand: the transform is a few lines, and the
// coefficient layout below is part of the project's file formats.
//
// Pixel arrays are row-major, index j * N + i (column i, row j), exactly as
// the octahedral / hemi-octahedral maps of docs/FORMATS.md.
//
// COEFFICIENT LAYOUT (the in-place layout of the non-standard decomposition;
// it is the `haar_index` of visibility.bin): coefficients are an N x N array,
// index r * N + c (row r, column c).
//   - index 0 is the scaling coefficient, sum(pixels) / N (= N * mean).
//   - level l = 0 .. log2(N) - 1 has 2^l x 2^l squares, each covering
//     N / 2^l x N / 2^l pixels; square (a, b) (column a, row b) covers pixel
//     columns [a, a+1) N / 2^l and rows [b, b+1) N / 2^l. With s = 2^l its three
//     wavelets are at
//        kDx  (varies along columns): row b,     column s + a
//        kDy  (varies along rows):    row s + b, column a
//        kDxy (checkerboard):         row s + b, column s + a
//     Value on the pixels of the square: +-2^l / N, with sign sx for kDx, sy
//     for kDy and sx * sy for kDxy, where sx = +1 on the left half (lower
//     column indices) and -1 on the right half, sy = +1 on the upper half (lower
//     row indices) and -1 on the lower half.
// The transform is orthogonal: sum_pixels f g = sum_k F_k G_k.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace relight {

// Wavelet type of a coefficient.
enum class HaarType : uint8_t { kScaling = 0, kDx = 1, kDy = 2, kDxy = 3 };

// Position of a coefficient in the tree.
struct HaarNode {
  HaarType type = HaarType::kScaling;
  int level = 0;  // 0 = coarsest; the scaling coefficient has level 0 as well
  int a = 0;      // square column at this level, 0 .. 2^level - 1
  int b = 0;      // square row at this level
};

// log2 of a power of two.
int Log2(int n);
// Tree position of coefficient `index` of an n x n transform.
HaarNode DecodeHaarIndex(uint32_t index, int n);
// Coefficient index of a wavelet (type != kScaling) of an n x n transform.
uint32_t HaarIndex(HaarType type, int level, int a, int b, int n);

// Forward transform: pixels (n x n, row-major) -> coefficients (layout above). May alias.
template <typename T>
void HaarForward(const T* pixels, int n, T* coeffs);
// Inverse transform: coefficients -> pixels. May alias.
template <typename T>
void HaarInverse(const T* coeffs, int n, T* pixels);

// Sparse coefficient vector of an n x n transform, indices ascending.
template <typename T>
struct BasicSparseCoefficients {
  int n = 0;                    // side of the transform
  std::vector<uint32_t> index;  // ascending coefficient indices
  std::vector<T> value;         // same length as index

  // Number of stored coefficients.
  size_t size() const { return index.size(); }
  // Sum of squared values.
  double Energy() const;
  // Writes the dense n*n vector (zeros elsewhere).
  template <typename U>
  void ToDense(U* dense) const;
};
using SparseCoefficients = BasicSparseCoefficients<float>;
using SparseCoefficientsD = BasicSparseCoefficients<double>;

// All coefficients with |value| > threshold (0 keeps every non-zero).
template <typename T>
BasicSparseCoefficients<T> SparseFromDense(const T* coeffs, int n, double threshold = 0.0);
// The k coefficients of largest magnitude (ties broken by lower index); non-linear approximation.
template <typename T>
BasicSparseCoefficients<T> KeepLargest(const T* coeffs, int n, size_t k);
// The fewest largest-magnitude coefficients whose energy is >= fraction of the total (0 < fraction <= 1).
template <typename T>
BasicSparseCoefficients<T> KeepEnergy(const T* coeffs, int n, double fraction);
// Indices sorted by decreasing magnitude (ties by lower index), for error-vs-k curves.
template <typename T>
std::vector<uint32_t> IndicesByMagnitude(const T* coeffs, int n);

// Truncates float coefficient vectors of up to 65,536 entries (a transport row: 32² to 256² Haar coefficients) to
// the fewest largest ones holding `fraction` of the energy, at most `cap`, as ascending indices. Ranked by (c²
// descending, index ascending), a strict order, so the kept set is unique; the same set as KeepEnergy followed by
// KeepLargest but for ties of c² between different |c|. O(n): a histogram of the energies by their float exponent
// (one octave per bucket) names the octave where the running sum from the top reaches the target; the octaves
// above it are kept, those below dropped, and only that octave's coefficients go through a selection on partial
// sums (each round an nth_element over the still undecided part, halving it). Sorting the candidates instead
// dominated the transport builds. Keeps its scratch between calls: one object per thread.
class EnergyTruncator {
 public:
  void Run(const float* coeffs, int size, double fraction, int cap, std::vector<uint16_t>* index,
           std::vector<float>* value);

 private:
  // Per non-zero coefficient one key that sorts like the ranking: the energy's bits (a non-negative float orders
  // like its bit pattern) above the complemented index, so one integer comparison ranks.
  std::vector<uint64_t> nz_, scratch_;
  std::vector<uint8_t> kept_;  // per coefficient: 1 when kept
  std::array<double, 256> octave_energy_{};
  std::array<uint32_t, 256> octave_count_{};
};

}  // namespace relight
