// Geometry of synthetic scenes: built-in procedural objects (sphere, torus
// knot, blob), object meshes from files brought into the scene's frame (+Z up,
// unit size, resting on the ground plane z = 0), the textured ground plane and
// box-shaped blockers. Every mesh comes with unit vertex normals and
// counter-clockwise faces seen from outside.
#pragma once

#include <Eigen/Core>
#include <string>

#include "geometry/mesh.h"

namespace relight {

// Icosphere of radius 1 around the origin with at least `min_vertices` vertices (exact radial normals).
TriangleMesh MakeSphere(int min_vertices);
// (2, 3) torus knot (trefoil) tube lying in the XY plane, about `min_vertices` vertices.
TriangleMesh MakeTorusKnot(int min_vertices);
// A lumpy, non-convex potato: a sphere displaced radially by seeded fractal noise.
TriangleMesh MakeBlob(int min_vertices, uint64_t seed);
// The built-in shape named `shape` ("sphere", "torus_knot", "blob"); throws UserError for others.
TriangleMesh MakeShape(const std::string& shape, int min_vertices, uint64_t seed);

// Rotates a mesh so that its axis `up` ("+x", "-x", "+y", "-y", "+z", "-z") points along +Z,
// then by `yaw_deg` about +Z. Throws UserError for an unknown axis name.
void RotateUp(TriangleMesh* mesh, const std::string& up, double yaw_deg);
// Scales so the largest bounding-box side is `size`, centres the box over the
// origin in X and Y and lifts it so its lowest point lies on z = 0.
void NormalizeOntoGround(TriangleMesh* mesh, double size);
// Splits every triangle into four (edge midpoints, positions unchanged, normals
// interpolated) until the mesh has at least `min_vertices` vertices.
void SubdivideToVertices(TriangleMesh* mesh, int min_vertices);
// Remeshes a mesh with more than `max_vertices` vertices down to about that
// many (CGAL isotropic remeshing via meshing/mesh_cleanup.h; every component
// kept, holes left open); properties are dropped, normals recomputed. Returns
// false (mesh untouched) when it already has at most `max_vertices`.
bool SimplifyToVertices(TriangleMesh* mesh, int max_vertices, const std::string& where);

// Square ground plane z = 0 of side `size` centred at the origin, `cells` x `cells` quads, normal +Z.
TriangleMesh MakeGroundPlane(double size, int cells);
// Round ground z = 0 of diameter `size` centred at the origin, normal +Z: `rings` concentric rings of
// vertices (ring k holds 6k, a hexagonal tiling of near-equilateral triangles whose edges are about
// size / (2 rings)), the outermost on the circle.
TriangleMesh MakeGroundDisk(double size, int rings);
// Closed axis-aligned box [min, max] with flat faces (vertices not shared between faces),
// each face split into `cells` x `cells` quads.
TriangleMesh MakeBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, int cells);

// Centre of the bounding box and the largest distance of a vertex from it.
void BoundingSphere(const TriangleMesh& mesh, Eigen::Vector3d* center, double* radius);

}  // namespace relight
