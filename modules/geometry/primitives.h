// Simple meshes for tests, benchmarks and synthetic scenes.
#pragma once

#include "geometry/mesh.h"

namespace relight {

// Icosahedron subdivided `subdivisions` times (each triangle into 4), projected onto the unit sphere:
// 10·4^s + 2 vertices, 20·4^s faces, counter-clockwise seen from outside, normals exactly radial.
TriangleMesh MakeIcosphere(int subdivisions);
// Octahedron subdivided `levels` times, projected onto the unit sphere: 4·4^l + 2 vertices, 8·4^l faces; its
// vertices include the six axis directions and, at every level, the octahedral maps' texel corners.
TriangleMesh MakeOctasphere(int levels);
// Axis-aligned box with outward faces.
TriangleMesh MakeBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);
// A grid of (nx+1)×(ny+1) vertices over [x0,x1]×[y0,y1] at height z, normals +Z.
TriangleMesh MakeGrid(float x0, float x1, float y0, float y1, float z, int nx, int ny);

}  // namespace relight
