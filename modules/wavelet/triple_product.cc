#include "wavelet/triple_product.h"

#include <algorithm>
#include <vector>

#include "core/error.h"

namespace relight {
namespace {

// Per-thread scratch, grown on demand and reused.
struct Scratch {
  std::vector<double> buf;
  double* Get(size_t size) {
    if (buf.size() < size) buf.resize(size);
    return buf.data();
  }
};
thread_local Scratch tl_means_cur, tl_means_next, tl_pyramid;
thread_local std::vector<double> tl_dense[3];

}  // namespace

template <typename T>
double TripleProduct(const T* F, const T* G, const T* H, int n) {
  const double inv_n = 1.0 / n;
  double e = double(F[0]) * G[0] * H[0] * inv_n;
  if (n == 1) return e;
  const size_t quarter = size_t(n) * n / 4;
  // Means of f, g, h over the squares of the current and the next level (structure of arrays).
  double* cur = tl_means_cur.Get(3 * quarter);
  double* next = tl_means_next.Get(3 * quarter);
  cur[0] = F[0] * inv_n;
  cur[quarter] = G[0] * inv_n;
  cur[2 * quarter] = H[0] * inv_n;
  double e_pairs = 0, e_triples = 0;
  for (int s = 1; s < n; s *= 2) {
    const double scale = s * inv_n;  // wavelet value at this level, 2^l / N
    const bool need_children = 2 * s < n;
    const size_t s2 = size_t(2 * s);
    double level_triples = 0;
    for (int b = 0; b < s; ++b) {
      const size_t rx = size_t(b) * n + s, ry = size_t(s + b) * n, rxy = size_t(s + b) * n + s;
      const double* mf = cur + size_t(b) * s;
      const double* mg = mf + quarter;
      const double* mh = mf + 2 * quarter;
      double* nf0 = next + size_t(2 * b) * s2;
      double* nf1 = nf0 + s2;
      for (int a = 0; a < s; ++a) {
        const double fx = F[rx + a], fy = F[ry + a], fxy = F[rxy + a];
        const double gx = G[rx + a], gy = G[ry + a], gxy = G[rxy + a];
        const double hx = H[rx + a], hy = H[ry + a], hxy = H[rxy + a];
        const double pf = mf[a], pg = mg[a], ph = mh[a];
        e_pairs += (fx * gx + fy * gy + fxy * gxy) * ph + (fx * hx + fy * hy + fxy * hxy) * pg +
                   (gx * hx + gy * hy + gxy * hxy) * pf;
        level_triples += fx * (gy * hxy + gxy * hy) + fy * (gx * hxy + gxy * hx) + fxy * (gx * hy + gy * hx);
        if (need_children) {
          // Child means: sign sx (+ left, - right) for Dx, sy (+ upper, - lower) for Dy, sx sy for Dxy.
          const double f00 = scale * (fx + fy + fxy), f01 = scale * (-fx + fy - fxy);
          const double f10 = scale * (fx - fy - fxy), f11 = scale * (-fx - fy + fxy);
          const double g00 = scale * (gx + gy + gxy), g01 = scale * (-gx + gy - gxy);
          const double g10 = scale * (gx - gy - gxy), g11 = scale * (-gx - gy + gxy);
          const double h00 = scale * (hx + hy + hxy), h01 = scale * (-hx + hy - hxy);
          const double h10 = scale * (hx - hy - hxy), h11 = scale * (-hx - hy + hxy);
          nf0[2 * a] = pf + f00;
          nf0[2 * a + 1] = pf + f01;
          nf1[2 * a] = pf + f10;
          nf1[2 * a + 1] = pf + f11;
          nf0[quarter + 2 * a] = pg + g00;
          nf0[quarter + 2 * a + 1] = pg + g01;
          nf1[quarter + 2 * a] = pg + g10;
          nf1[quarter + 2 * a + 1] = pg + g11;
          nf0[2 * quarter + 2 * a] = ph + h00;
          nf0[2 * quarter + 2 * a + 1] = ph + h01;
          nf1[2 * quarter + 2 * a] = ph + h10;
          nf1[2 * quarter + 2 * a + 1] = ph + h11;
        }
      }
    }
    e_triples += scale * level_triples;
    std::swap(cur, next);
  }
  return e + e_pairs + e_triples;
}

template <typename T>
void ProductProjection(const T* F, const T* G, int n, T* out) {
  const double inv_n = 1.0 / n;
  const size_t total = size_t(n) * n;
  double dot = 0;
  for (size_t k = 0; k < total; ++k) dot += double(F[k]) * G[k];
  if (n == 1) {
    out[0] = T(dot * inv_n);
    return;
  }
  const int levels = Log2(n);
  // D pyramid: level l occupies [(4^l - 1) / 3, (4^(l+1) - 1) / 3), row-major s x s.
  double* d = tl_pyramid.Get((total - 1) / 3);
  auto offset = [](int l) { return ((size_t(1) << (2 * l)) - 1) / 3; };
  for (int l = levels - 1; l >= 0; --l) {
    const int s = 1 << l;
    double* dl = d + offset(l);
    const double* dc = l + 1 < levels ? d + offset(l + 1) : nullptr;
    for (int b = 0; b < s; ++b) {
      const size_t rx = size_t(b) * n + s, ry = size_t(s + b) * n, rxy = size_t(s + b) * n + s;
      for (int a = 0; a < s; ++a) {
        double v = double(F[rx + a]) * G[rx + a] + double(F[ry + a]) * G[ry + a] + double(F[rxy + a]) * G[rxy + a];
        if (dc) {
          const double* c0 = dc + size_t(2 * b) * (2 * s) + 2 * a;
          v += c0[0] + c0[1] + c0[2 * s] + c0[2 * s + 1];
        }
        dl[size_t(b) * s + a] = v;
      }
    }
  }
  // Top down: means of f and g, and the output.
  const size_t quarter = total / 4;
  double* cur = tl_means_cur.Get(2 * quarter);
  double* next = tl_means_next.Get(2 * quarter);
  cur[0] = F[0] * inv_n;
  cur[quarter] = G[0] * inv_n;
  out[0] = T(dot * inv_n);
  for (int l = 0; l < levels; ++l) {
    const int s = 1 << l;
    const double scale = s * inv_n;
    const bool has_children = l + 1 < levels;
    const double* dc = has_children ? d + offset(l + 1) : nullptr;
    const size_t s2 = size_t(2 * s);
    for (int b = 0; b < s; ++b) {
      const size_t rx = size_t(b) * n + s, ry = size_t(s + b) * n, rxy = size_t(s + b) * n + s;
      const double* mf = cur + size_t(b) * s;
      const double* mg = mf + quarter;
      double* n0 = next + size_t(2 * b) * s2;
      double* n1 = n0 + s2;
      for (int a = 0; a < s; ++a) {
        const double fx = F[rx + a], fy = F[ry + a], fxy = F[rxy + a];
        const double gx = G[rx + a], gy = G[ry + a], gxy = G[rxy + a];
        const double pf = mf[a], pg = mg[a];
        double tx = fx * pg + gx * pf + scale * (fy * gxy + fxy * gy);
        double ty = fy * pg + gy * pf + scale * (fx * gxy + fxy * gx);
        double txy = fxy * pg + gxy * pf + scale * (fx * gy + fy * gx);
        if (has_children) {
          const double* c0 = dc + size_t(2 * b) * s2 + 2 * a;
          const double d00 = c0[0], d01 = c0[1], d10 = c0[s2], d11 = c0[s2 + 1];
          tx += scale * (d00 - d01 + d10 - d11);
          ty += scale * (d00 + d01 - d10 - d11);
          txy += scale * (d00 - d01 - d10 + d11);
          n0[2 * a] = pf + scale * (fx + fy + fxy);
          n0[2 * a + 1] = pf + scale * (-fx + fy - fxy);
          n1[2 * a] = pf + scale * (fx - fy - fxy);
          n1[2 * a + 1] = pf + scale * (-fx - fy + fxy);
          n0[quarter + 2 * a] = pg + scale * (gx + gy + gxy);
          n0[quarter + 2 * a + 1] = pg + scale * (-gx + gy - gxy);
          n1[quarter + 2 * a] = pg + scale * (gx - gy - gxy);
          n1[quarter + 2 * a + 1] = pg + scale * (-gx - gy + gxy);
        }
        out[rx + a] = T(tx);
        out[ry + a] = T(ty);
        out[rxy + a] = T(txy);
      }
    }
    std::swap(cur, next);
  }
}

template <typename T>
double HaarSquareMean(const T* c, int n, int level, int a, int b) {
  const double inv_n = 1.0 / n;
  double m = c[0] * inv_n;
  for (int l = 0; l < level; ++l) {
    const int shift = level - l;
    const int aa = a >> shift, bb = b >> shift;
    const double sx = ((a >> (shift - 1)) & 1) ? -1.0 : 1.0;
    const double sy = ((b >> (shift - 1)) & 1) ? -1.0 : 1.0;
    const int s = 1 << l;
    const double cx = c[size_t(bb) * n + s + aa], cy = c[size_t(s + bb) * n + aa], cxy = c[size_t(s + bb) * n + s + aa];
    m += s * inv_n * (sx * cx + sy * cy + sx * sy * cxy);
  }
  return m;
}

namespace {

// Scatters sparse vectors into per-thread dense arrays, cleared again on destruction.
template <typename T>
class DenseView {
 public:
  DenseView(const BasicSparseCoefficients<T>& s, int slot) : s_(s), d_(tl_dense[slot]) {
    const size_t total = size_t(s.n) * s.n;
    if (d_.size() < total) d_.assign(total, 0.0);
    for (size_t k = 0; k < s.index.size(); ++k) d_[s.index[k]] = s.value[k];
  }
  ~DenseView() {
    for (uint32_t k : s_.index) d_[k] = 0.0;
  }
  const double* data() const { return d_.data(); }

 private:
  const BasicSparseCoefficients<T>& s_;
  std::vector<double>& d_;
};

// Indices of the three wavelets of the square holding wavelet `node`.
void SquareIndices(const HaarNode& node, int n, uint32_t idx[4]) {
  idx[1] = HaarIndex(HaarType::kDx, node.level, node.a, node.b, n);
  idx[2] = HaarIndex(HaarType::kDy, node.level, node.a, node.b, n);
  idx[3] = HaarIndex(HaarType::kDxy, node.level, node.a, node.b, n);
}

}  // namespace

template <typename T>
double TripleProduct(const BasicSparseCoefficients<T>& f, const BasicSparseCoefficients<T>& g,
                     const BasicSparseCoefficients<T>& h) {
  const int n = f.n;
  RELIGHT_CHECK(g.n == n && h.n == n) << "sparse triple product of different sizes";
  const DenseView<T> df(f, 0), dg(g, 1), dh(h, 2);
  const double* F = df.data();
  const double* G = dg.data();
  const double* H = dh.data();
  const double inv_n = 1.0 / n;
  double e = F[0] * G[0] * H[0] * inv_n;
  uint32_t idx[4];
  for (size_t k = 0; k < f.index.size(); ++k) {
    const uint32_t i = f.index[k];
    if (i == 0) continue;
    const double fv = f.value[k];
    const HaarNode node = DecodeHaarIndex(i, n);
    if (G[i] != 0) e += fv * G[i] * HaarSquareMean(H, n, node.level, node.a, node.b);
    if (H[i] != 0) e += fv * H[i] * HaarSquareMean(G, n, node.level, node.a, node.b);
    // Three distinct types on the same square: f takes type t, g and h the other two.
    SquareIndices(node, n, idx);
    const int t = int(node.type);
    const int u = t == 1 ? 2 : 1, v = t == 3 ? 2 : 3;
    e += (double(1 << node.level) * inv_n) * fv * (G[idx[u]] * H[idx[v]] + G[idx[v]] * H[idx[u]]);
  }
  for (size_t k = 0; k < g.index.size(); ++k) {
    const uint32_t i = g.index[k];
    if (i == 0 || H[i] == 0) continue;
    const HaarNode node = DecodeHaarIndex(i, n);
    e += g.value[k] * H[i] * HaarSquareMean(F, n, node.level, node.a, node.b);
  }
  return e;
}

template <typename T>
void AccumulateProductProjection(const BasicSparseCoefficients<T>& f, const BasicSparseCoefficients<T>& g, double scale,
                                 double* out) {
  const int n = f.n;
  RELIGHT_CHECK(g.n == n) << "sparse product projection of different sizes";
  const DenseView<T> df(f, 0), dg(g, 1);
  const double* F = df.data();
  const double* G = dg.data();
  const double inv_n = 1.0 / n;
  uint32_t idx[4];
  for (size_t k = 0; k < f.index.size(); ++k) {
    const uint32_t i = f.index[k];
    const double fv = f.value[k];
    if (i == 0) {
      out[0] += scale * inv_n * fv * G[0];
      continue;
    }
    const HaarNode node = DecodeHaarIndex(i, n);
    const double wavelet = double(1 << node.level) * inv_n;
    // F_k P_g(q).
    out[i] += scale * fv * HaarSquareMean(G, n, node.level, node.a, node.b);
    // Same square, other types: T_third += scale 2^l/N F_t G_u.
    SquareIndices(node, n, idx);
    const int t = int(node.type);
    for (int u = 1; u <= 3; ++u) {
      if (u == t || G[idx[u]] == 0) continue;
      out[idx[6 - t - u]] += scale * wavelet * fv * G[idx[u]];
    }
    // Identical wavelets: F_k G_k feeds the scaling coefficient and every coarser wavelet above it.
    const double gv = G[i];
    if (gv == 0) continue;
    const double d = fv * gv;
    out[0] += scale * inv_n * d;
    for (int l = 0; l < node.level; ++l) {
      const int shift = node.level - l;
      const int aa = node.a >> shift, bb = node.b >> shift;
      const double sx = ((node.a >> (shift - 1)) & 1) ? -1.0 : 1.0;
      const double sy = ((node.b >> (shift - 1)) & 1) ? -1.0 : 1.0;
      const int s = 1 << l;
      const double w = scale * s * inv_n * d;
      out[size_t(bb) * n + s + aa] += w * sx;
      out[size_t(s + bb) * n + aa] += w * sy;
      out[size_t(s + bb) * n + s + aa] += w * sx * sy;
    }
  }
  for (size_t k = 0; k < g.index.size(); ++k) {
    const uint32_t i = g.index[k];
    if (i == 0) continue;  // G_0 F_0 counted above (from f's side) when f holds index 0
    const HaarNode node = DecodeHaarIndex(i, n);
    out[i] += scale * g.value[k] * HaarSquareMean(F, n, node.level, node.a, node.b);
  }
}

#define RELIGHT_INSTANTIATE_TRIPLE(T)                                                                                \
  template double TripleProduct<T>(const T*, const T*, const T*, int);                                               \
  template void ProductProjection<T>(const T*, const T*, int, T*);                                                   \
  template double TripleProduct<T>(const BasicSparseCoefficients<T>&, const BasicSparseCoefficients<T>&,             \
                                   const BasicSparseCoefficients<T>&);                                               \
  template void AccumulateProductProjection<T>(const BasicSparseCoefficients<T>&, const BasicSparseCoefficients<T>&, \
                                               double, double*);                                                     \
  template double HaarSquareMean<T>(const T*, int, int, int, int);

RELIGHT_INSTANTIATE_TRIPLE(float)
RELIGHT_INSTANTIATE_TRIPLE(double)

}  // namespace relight
