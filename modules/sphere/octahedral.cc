#include "sphere/octahedral.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <queue>

#include "core/error.h"

namespace relight {
namespace {

double SignNotZero(double v) { return v >= 0.0 ? 1.0 : -1.0; }

// A convex polygon in the plane, at most 8 vertices after clipping a rectangle by 3 half-planes.
struct Polygon {
  Eigen::Vector2d v[12];
  int size = 0;
};

// Keeps the part of `in` where n . p >= c (Sutherland-Hodgman).
Polygon ClipHalfPlane(const Polygon& in, const Eigen::Vector2d& n, double c) {
  Polygon out;
  for (int k = 0; k < in.size; ++k) {
    const Eigen::Vector2d& p = in.v[k];
    const Eigen::Vector2d& q = in.v[(k + 1) % in.size];
    const double dp = n.dot(p) - c, dq = n.dot(q) - c;
    if (dp >= 0) out.v[out.size++] = p;
    if ((dp >= 0) != (dq >= 0)) {
      const double t = dp / (dp - dq);
      out.v[out.size++] = p + t * (q - p);
    }
  }
  return out;
}

// Solid angle of the spherical triangle spanned by unit vectors a, b, c
// (Van Oosterom & Strackee 1983).
double TriangleSolidAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double num = std::abs(a.dot(b.cross(c)));
  const double den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
  return 2.0 * std::atan2(num, den);
}

// Area of the radial projection of a planar convex polygon (points on one octahedron face).
double ProjectedPolygonArea(const Eigen::Vector3d* pts, int n) {
  if (n < 3) return 0.0;
  double sum = 0;
  const Eigen::Vector3d a = pts[0].normalized();
  Eigen::Vector3d b = pts[1].normalized();
  for (int k = 2; k < n; ++k) {
    const Eigen::Vector3d c = pts[k].normalized();
    sum += TriangleSolidAngle(a, b, c);
    b = c;
  }
  return sum;
}

// Twice the signed area (shoelace); pieces that merely touch a fold line have ~0 area.
double PlanarArea(const Polygon& p) {
  double a = 0;
  for (int k = 0; k < p.size; ++k) {
    const Eigen::Vector2d& u = p.v[k];
    const Eigen::Vector2d& w = p.v[(k + 1) % p.size];
    a += u.x() * w.y() - u.y() * w.x();
  }
  return std::abs(a);
}

Polygon Rect(double x0, double y0, double x1, double y1) {
  Polygon p;
  p.size = 4;
  p.v[0] = {x0, y0};
  p.v[1] = {x1, y0};
  p.v[2] = {x1, y1};
  p.v[3] = {x0, y1};
  return p;
}

}  // namespace

Eigen::Vector2d OctEncode(const Eigen::Vector3d& dir) {
  const double l1 = std::abs(dir.x()) + std::abs(dir.y()) + std::abs(dir.z());
  double x = dir.x() / l1, y = dir.y() / l1;
  if (dir.z() < 0) {
    const double ox = x;
    x = (1.0 - std::abs(y)) * SignNotZero(ox);
    y = (1.0 - std::abs(ox)) * SignNotZero(y);
  }
  return {x * 0.5 + 0.5, y * 0.5 + 0.5};
}

Eigen::Vector3d OctDecode(const Eigen::Vector2d& st) {
  double x = st.x() * 2.0 - 1.0, y = st.y() * 2.0 - 1.0;
  const double z = 1.0 - std::abs(x) - std::abs(y);
  if (z < 0) {
    const double ox = x;
    x = (1.0 - std::abs(y)) * SignNotZero(ox);
    y = (1.0 - std::abs(ox)) * SignNotZero(y);
  }
  return Eigen::Vector3d(x, y, z).normalized();
}

Eigen::Vector2d HemiOctEncode(const Eigen::Vector3d& dir_local) {
  const double z = std::max(dir_local.z(), 0.0);
  const double l1 = std::abs(dir_local.x()) + std::abs(dir_local.y()) + z;
  const double px = dir_local.x() / l1, py = dir_local.y() / l1;
  return {px + py, px - py};
}

Eigen::Vector3d HemiOctDecode(const Eigen::Vector2d& ab) {
  const double x = 0.5 * (ab.x() + ab.y()), y = 0.5 * (ab.x() - ab.y());
  const double z = std::max(0.0, 1.0 - std::abs(x) - std::abs(y));
  return Eigen::Vector3d(x, y, z).normalized();
}

Eigen::Vector3d OctTexelDirection(int i, int j, int n) { return OctDecode({(i + 0.5) / n, (j + 0.5) / n}); }

Eigen::Vector3d HemiOctTexelDirection(int i, int j, int n) {
  return HemiOctDecode({-1.0 + 2.0 * (i + 0.5) / n, -1.0 + 2.0 * (j + 0.5) / n});
}

int OctRectPolygons(double s0, double t0, double s1, double t1, SpherePolygon* pieces) {
  const Polygon rect = Rect(2 * s0 - 1, 2 * t0 - 1, 2 * s1 - 1, 2 * t1 - 1);
  const double rect_area = PlanarArea(rect);
  int count = 0;
  for (int quadrant = 0; quadrant < 4; ++quadrant) {
    const double sx = (quadrant & 1) ? -1.0 : 1.0, sy = (quadrant & 2) ? -1.0 : 1.0;
    Polygon q = ClipHalfPlane(rect, {sx, 0}, 0);
    q = ClipHalfPlane(q, {0, sy}, 0);
    if (q.size < 3) continue;
    for (int outer = 0; outer < 2; ++outer) {
      // Inner diamond: sx x + sy y <= 1 (upper hemisphere); outer corner: >= 1 (lower).
      const Polygon part = outer ? ClipHalfPlane(q, {sx, sy}, 1.0) : ClipHalfPlane(q, {-sx, -sy}, -1.0);
      if (part.size < 3 || PlanarArea(part) <= 1e-14 * rect_area) continue;
      SpherePolygon& out = pieces[count++];
      out.size = part.size;
      for (int k = 0; k < part.size; ++k) {
        const double x = part.v[k].x(), y = part.v[k].y();
        const double z = 1.0 - sx * x - sy * y;
        out.v[k] = outer ? Eigen::Vector3d(sx * (1.0 - sy * y), sy * (1.0 - sx * x), z) : Eigen::Vector3d(x, y, z);
      }
    }
  }
  return count;
}

int HemiOctRectPolygons(double a0, double b0, double a1, double b1, SpherePolygon* pieces) {
  const Polygon rect = Rect(a0, b0, a1, b1);
  const double rect_area = PlanarArea(rect);
  int count = 0;
  for (int quadrant = 0; quadrant < 4; ++quadrant) {
    const double sx = (quadrant & 1) ? -1.0 : 1.0, sy = (quadrant & 2) ? -1.0 : 1.0;
    // x = (a+b)/2 has sign sx, y = (a-b)/2 has sign sy.
    Polygon q = ClipHalfPlane(rect, {sx, sx}, 0);
    q = ClipHalfPlane(q, {sy, -sy}, 0);
    if (q.size < 3 || PlanarArea(q) <= 1e-14 * rect_area) continue;
    SpherePolygon& out = pieces[count++];
    out.size = q.size;
    for (int k = 0; k < q.size; ++k) {
      const double x = 0.5 * (q.v[k].x() + q.v[k].y()), y = 0.5 * (q.v[k].x() - q.v[k].y());
      out.v[k] = {x, y, 1.0 - sx * x - sy * y};
    }
  }
  return count;
}

double SpherePolygonArea(const SpherePolygon& polygon) { return ProjectedPolygonArea(polygon.v, polygon.size); }

SpherePolygon ClipToCone(const SpherePolygon& polygon, const SpherePolygon& cone) {
  if (cone.size < 3 || polygon.size < 3) return SpherePolygon();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int k = 0; k < cone.size; ++k) centre += cone.v[k].normalized();
  SpherePolygon cur = polygon, next;
  int planes = 0;
  for (int e = 0; e < cone.size && cur.size >= 3; ++e) {
    Eigen::Vector3d m = cone.v[e].cross(cone.v[(e + 1) % cone.size]);
    const double len = m.norm();
    if (len < 1e-14) continue;  // degenerate edge
    ++planes;
    m /= len;
    if (m.dot(centre) < 0) m = -m;
    next.size = 0;
    for (int k = 0; k < cur.size; ++k) {
      const Eigen::Vector3d& p = cur.v[k];
      const Eigen::Vector3d& q = cur.v[(k + 1) % cur.size];
      const double dp = m.dot(p), dq = m.dot(q);
      if (dp >= 0) next.v[next.size++] = p;
      if ((dp >= 0) != (dq >= 0)) next.v[next.size++] = p + (dp / (dp - dq)) * (q - p);
      if (next.size > 10) break;  // cannot happen for convex inputs; guards the fixed storage
    }
    cur = next;
  }
  if (cur.size < 3 || planes < 3) cur.size = 0;  // fewer than 3 planes: a degenerate cone
  return cur;
}

double OctRectSolidAngle(double s0, double t0, double s1, double t1) {
  SpherePolygon pieces[8];
  const int count = OctRectPolygons(s0, t0, s1, t1, pieces);
  double total = 0;
  for (int k = 0; k < count; ++k) total += SpherePolygonArea(pieces[k]);
  return total;
}

double HemiOctRectSolidAngle(double a0, double b0, double a1, double b1) {
  SpherePolygon pieces[4];
  const int count = HemiOctRectPolygons(a0, b0, a1, b1, pieces);
  double total = 0;
  for (int k = 0; k < count; ++k) total += SpherePolygonArea(pieces[k]);
  return total;
}

double OctTexelSolidAngle(int i, int j, int n) {
  return OctRectSolidAngle(double(i) / n, double(j) / n, double(i + 1) / n, double(j + 1) / n);
}

double HemiOctTexelSolidAngle(int i, int j, int n) {
  return HemiOctRectSolidAngle(-1.0 + 2.0 * i / n, -1.0 + 2.0 * j / n, -1.0 + 2.0 * (i + 1) / n,
                               -1.0 + 2.0 * (j + 1) / n);
}

double OctJacobian(const Eigen::Vector2d& st) {
  const double x = 2 * st.x() - 1, y = 2 * st.y() - 1;
  const double z = 1.0 - std::abs(x) - std::abs(y);
  // On the lower half the fold is area preserving, and |p| is the same expression.
  const double xf = z < 0 ? 1.0 - std::abs(y) : std::abs(x);
  const double yf = z < 0 ? 1.0 - std::abs(x) : std::abs(y);
  const double r2 = xf * xf + yf * yf + z * z;
  return 4.0 / (r2 * std::sqrt(r2));
}

double HemiOctJacobian(const Eigen::Vector2d& ab) {
  const double x = 0.5 * (ab.x() + ab.y()), y = 0.5 * (ab.x() - ab.y());
  const double z = 1.0 - std::abs(x) - std::abs(y);
  const double r2 = x * x + y * y + z * z;
  return 0.5 / (r2 * std::sqrt(r2));
}

Eigen::Vector2i OctTexelOf(const Eigen::Vector3d& dir, int n) {
  const Eigen::Vector2d st = OctEncode(dir);
  return {std::clamp(int(st.x() * n), 0, n - 1), std::clamp(int(st.y() * n), 0, n - 1)};
}

Eigen::Vector2i HemiOctTexelOf(const Eigen::Vector3d& dir_local, int n) {
  const Eigen::Vector2d ab = HemiOctEncode(dir_local);
  return {std::clamp(int((ab.x() + 1.0) * 0.5 * n), 0, n - 1), std::clamp(int((ab.y() + 1.0) * 0.5 * n), 0, n - 1)};
}

Eigen::Vector2i OctWrapTexel(int i, int j, int n) {
  if (i < 0) {
    i = -1 - i;
    j = n - 1 - j;
  } else if (i >= n) {
    i = 2 * n - 1 - i;
    j = n - 1 - j;
  }
  if (j < 0) {
    j = -1 - j;
    i = n - 1 - i;
  } else if (j >= n) {
    j = 2 * n - 1 - j;
    i = n - 1 - i;
  }
  return {i, j};
}

std::vector<Eigen::Vector3d> OctTexelDirections(int n) {
  std::vector<Eigen::Vector3d> out(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out[size_t(j) * n + i] = OctTexelDirection(i, j, n);
  return out;
}

Eigen::Vector3d BrightestLobeDirection(const std::vector<double>& luminance, int n, double threshold_fraction) {
  RELIGHT_CHECK(IsPowerOfTwo(n) && luminance.size() == size_t(n) * n);
  const int peak = int(std::max_element(luminance.begin(), luminance.end()) - luminance.begin());
  const double level = threshold_fraction * luminance[peak];
  std::vector<char> in(luminance.size(), 0);
  std::queue<int> frontier;
  frontier.push(peak);
  in[peak] = 1;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  while (!frontier.empty()) {
    const int k = frontier.front(), i = k % n, j = k / n;
    frontier.pop();
    sum += luminance[k] * OctTexelSolidAngle(i, j, n) * OctTexelDirection(i, j, n);
    const int di[4] = {-1, 1, 0, 0}, dj[4] = {0, 0, -1, 1};
    for (int e = 0; e < 4; ++e) {
      const Eigen::Vector2i t = OctWrapTexel(i + di[e], j + dj[e], n);
      const int m = t.y() * n + t.x();
      if (in[m] || luminance[m] < level) continue;
      in[m] = 1;
      frontier.push(m);
    }
  }
  return sum.norm() > 0 ? Eigen::Vector3d(sum.normalized()) : OctTexelDirection(peak % n, peak / n, n);
}

Eigen::Vector3d CompactLobeDirection(const std::vector<double>& luminance, int n) {
  RELIGHT_CHECK(IsPowerOfTwo(n) && n >= 4 && luminance.size() == size_t(n) * n);
  const int peak = int(std::max_element(luminance.begin(), luminance.end()) - luminance.begin());
  const int pi = peak % n, pj = peak / n;
  auto texel = [&](int di, int dj) {  // two wraps: a step of 2 beyond a corner folds twice
    const Eigen::Vector2i t = OctWrapTexel(pi + di, pj + dj, n);
    return OctWrapTexel(t.x(), t.y(), n);
  };
  std::vector<double> ring;
  for (int dj = -2; dj <= 2; ++dj)
    for (int di = -2; di <= 2; ++di)
      if (std::max(std::abs(di), std::abs(dj)) == 2) {
        const Eigen::Vector2i t = texel(di, dj);
        ring.push_back(luminance[t.y() * n + t.x()]);
      }
  std::nth_element(ring.begin(), ring.begin() + ring.size() / 2, ring.end());
  const double background = ring[ring.size() / 2];
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int dj = -1; dj <= 1; ++dj)
    for (int di = -1; di <= 1; ++di) {
      const Eigen::Vector2i t = texel(di, dj);
      const double w = std::max(0.0, luminance[t.y() * n + t.x()] - background) * OctTexelSolidAngle(t.x(), t.y(), n);
      sum += w * OctTexelDirection(t.x(), t.y(), n);
    }
  return sum.norm() > 0 ? Eigen::Vector3d(sum.normalized()) : OctTexelDirection(pi, pj, n);
}

std::vector<double> OctTexelSolidAngles(int n) {
  std::vector<double> out(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out[size_t(j) * n + i] = OctTexelSolidAngle(i, j, n);
  return out;
}

std::vector<Eigen::Vector3d> HemiOctTexelDirections(int n) {
  std::vector<Eigen::Vector3d> out(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out[size_t(j) * n + i] = HemiOctTexelDirection(i, j, n);
  return out;
}

std::vector<double> HemiOctTexelSolidAngles(int n) {
  std::vector<double> out(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out[size_t(j) * n + i] = HemiOctTexelSolidAngle(i, j, n);
  return out;
}

}  // namespace relight
