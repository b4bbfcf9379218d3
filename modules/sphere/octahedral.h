// Octahedral (full sphere) and hemi-octahedral (upper hemisphere of a local
// frame) parameterisations, exactly as docs/FORMATS.md fixes them, plus texel
// centres, exact texel solid angles and the fold-aware neighbour rule.
//
// Seed §4 (Haber et al. 2009) stores environment maps on an octahedral map and
// per-vertex functions on a hemi-octahedral map. Neither map is equal-area, so
// texel solid angles are computed exactly: every texel, clipped against the
// fold lines, maps affinely onto a planar polygon on one face of the
// octahedron |x|+|y|+|z| = 1, whose radial projection is a spherical polygon
// with great-circle edges; its area is a sum of Van Oosterom-Strackee triangle
// areas. Written by hand: no library offers these exact areas.
//
// Conventions (column i <-> s or a, row j <-> t or b, row 0 at t = 0 / b = -1):
//   octahedral texel (i, j) of an N x N map covers s in [i/N, (i+1)/N), t in [j/N, (j+1)/N);
//   hemi-octahedral texel (i, j) covers a in [-1 + 2i/N, -1 + 2(i+1)/N), b likewise with j.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace relight {

// Full-sphere direction (any length > 0) -> (s, t) in [0, 1]^2.
Eigen::Vector2d OctEncode(const Eigen::Vector3d& dir);
// (s, t) in [0, 1]^2 -> unit direction.
Eigen::Vector3d OctDecode(const Eigen::Vector2d& st);
// Upper-hemisphere local direction (z >= 0, any length > 0) -> (a, b) in [-1, 1]^2.
// Directions with z < 0 are clamped to the horizon (z treated as 0).
Eigen::Vector2d HemiOctEncode(const Eigen::Vector3d& dir_local);
// (a, b) in [-1, 1]^2 -> unit local direction with z >= 0.
Eigen::Vector3d HemiOctDecode(const Eigen::Vector2d& ab);

// Unit direction of the centre of octahedral texel (i, j) of an n x n map.
Eigen::Vector3d OctTexelDirection(int i, int j, int n);
// Exact solid angle [sr] of octahedral texel (i, j) of an n x n map.
double OctTexelSolidAngle(int i, int j, int n);
// Unit local direction of the centre of hemi-octahedral texel (i, j) of an n x n map.
Eigen::Vector3d HemiOctTexelDirection(int i, int j, int n);
// Exact solid angle [sr] of hemi-octahedral texel (i, j) of an n x n map.
double HemiOctTexelSolidAngle(int i, int j, int n);

// Exact solid angle [sr] of the rectangle [s0,s1] x [t0,t1] of the octahedral square.
double OctRectSolidAngle(double s0, double t0, double s1, double t1);
// Exact solid angle [sr] of the rectangle [a0,a1] x [b0,b1] of the hemi-octahedral square.
double HemiOctRectSolidAngle(double a0, double b0, double a1, double b1);

// Solid angle per unit (s, t) area at (s, t): d(omega) = OctJacobian * ds dt (= 4 / |p|^3).
double OctJacobian(const Eigen::Vector2d& st);
// Solid angle per unit (a, b) area at (a, b): d(omega) = HemiOctJacobian * da db (= 0.5 / |p|^3).
double HemiOctJacobian(const Eigen::Vector2d& ab);

// Texel index (column i, row j) holding a direction, clamped into [0, n).
Eigen::Vector2i OctTexelOf(const Eigen::Vector3d& dir, int n);
// Texel index (column i, row j) of a local upper-hemisphere direction, clamped into [0, n).
Eigen::Vector2i HemiOctTexelOf(const Eigen::Vector3d& dir_local, int n);

// Maps an out-of-range octahedral texel index (one step beyond the border,
// e.g. i = -1) to the texel that is its neighbour on the sphere (fold rule:
// (-1, j) -> (0, n-1-j), (n, j) -> (n-1, n-1-j), likewise for rows).
Eigen::Vector2i OctWrapTexel(int i, int j, int n);

// The direction of the brightest lobe of an n x n octahedral map given its per-texel luminance (row-major): the
// solid-angle-weighted luminance centroid of the texels connected to the brightest one (across the folds) whose
// luminance is at least `threshold_fraction` of its. A map of one bright texel gives that texel's direction.
// Suits a broad lobe (a spread-out light, a recovered map's blurred sun).
Eigen::Vector3d BrightestLobeDirection(const std::vector<double>& luminance, int n, double threshold_fraction = 0.5);
// The direction of a compact source (a sun of a few texels) on a bright background (a sky): the brightest texel's
// 3x3 neighbourhood, each texel weighted by its luminance above the median of the 16 texels around that
// neighbourhood, times its solid angle. Unlike BrightestLobeDirection, the sky around the sun does not pull the
// direction towards the centre of the bright region.
Eigen::Vector3d CompactLobeDirection(const std::vector<double>& luminance, int n);

// All texel directions of an n x n octahedral map, row-major (index j*n + i).
std::vector<Eigen::Vector3d> OctTexelDirections(int n);
// All exact texel solid angles of an n x n octahedral map, row-major.
std::vector<double> OctTexelSolidAngles(int n);
// All texel directions (local) of an n x n hemi-octahedral map, row-major.
std::vector<Eigen::Vector3d> HemiOctTexelDirections(int n);
// All exact texel solid angles of an n x n hemi-octahedral map, row-major.
std::vector<double> HemiOctTexelSolidAngles(int n);

// A convex polygon on one face of the octahedron |x|+|y|+|z| = 1 (vertices not
// normalised, in order); its radial projection is a convex spherical polygon
// with great-circle edges. Used for exact texel areas and texel overlaps.
struct SpherePolygon {
  int size = 0;
  Eigen::Vector3d v[12];
};
// The pieces (at most 8, one per octahedron face) of the rectangle [s0,s1] x [t0,t1] of the octahedral square.
int OctRectPolygons(double s0, double t0, double s1, double t1, SpherePolygon* pieces);
// The pieces (at most 4) of the rectangle [a0,a1] x [b0,b1] of the hemi-octahedral square (local frame).
int HemiOctRectPolygons(double a0, double b0, double a1, double b1, SpherePolygon* pieces);
// Exact solid angle [sr] of the radial projection of a polygon.
double SpherePolygonArea(const SpherePolygon& polygon);
// The part of `polygon` inside the cone spanned by the convex polygon `cone` (both planar, any frames alike).
SpherePolygon ClipToCone(const SpherePolygon& polygon, const SpherePolygon& cone);

// True when n is a power of two >= 1.
inline bool IsPowerOfTwo(int n) { return n > 0 && (n & (n - 1)) == 0; }

}  // namespace relight
