// Triple product integrals and product projections in the 2D Haar basis, in
// time linear in the number of coefficients.
//
// Ng, Ramamoorthi, Hanrahan, "Triple Product Wavelet Integrals for All-Frequency
// Relighting" (SIGGRAPH 2004), used by Haber et al. 2009 eq. 5. With the
// discrete orthonormal transform of wavelet/haar.h, for pixel arrays f, g, h
// with coefficients F, G, H:
//   sum_pixels f g h = F0 G0 H0 / N
//                    + sum_w [F_w G_w P_h(q_w) + F_w H_w P_g(q_w) + G_w H_w P_f(q_w)]
//                    + sum_squares (2^l / N) sum_{a,b,c distinct types} F_a G_b H_c,
// where P_h(q) is the mean of h over the square q of wavelet w, obtained top
// down from the coefficients (a mean pyramid). The same tree gives the product
// projection T = Haar(f . g) (one row of the lighting system): for a wavelet k
// of type t on square q at level l,
//   T_k = F_k P_g(q) + G_k P_f(q) + (2^l / N) (F_u G_v + F_v G_u)
//       + (2^l / N) sum_{children c of q} sign_t(c) D(c),
// D(c) = sum of F_w G_w over all wavelets w in the subtree of c; T_0 = F.G / N.
// These are the tripling-coefficient rules of ../shared/METHOD.md in discrete
// normalisation (continuous coefficient C becomes C / N). Written by hand: no
// library implements Haar triple products.
//
// Dense inputs: O(N^2), no allocation after the first call per thread.
// Sparse inputs (indices ascending): O(k log N) for k stored coefficients.
#pragma once

#include "wavelet/haar.h"

namespace relight {

// sum over pixels of f g h, from the three dense coefficient arrays of an n x n transform.
template <typename T>
double TripleProduct(const T* f, const T* g, const T* h, int n);
// Haar coefficients of the pixel-wise product f . g (dense, n*n entries written to `out`).
template <typename T>
void ProductProjection(const T* f, const T* g, int n, T* out);

// sum over pixels of f g h for sparse coefficient vectors (same n).
template <typename T>
double TripleProduct(const BasicSparseCoefficients<T>& f, const BasicSparseCoefficients<T>& g,
                     const BasicSparseCoefficients<T>& h);
// out += scale * Haar(f . g) for sparse f, g; `out` is dense (n*n), untouched where the product has no support.
template <typename T>
void AccumulateProductProjection(const BasicSparseCoefficients<T>& f, const BasicSparseCoefficients<T>& g, double scale,
                                 double* out);

// Mean over square (a, b) at `level` of the function with dense coefficients `c` (ancestor walk, O(level)).
template <typename T>
double HaarSquareMean(const T* c, int n, int level, int a, int b);

}  // namespace relight
