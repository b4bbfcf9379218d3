// Simple meshes for tests, benchmarks and synthetic scenes.
#pragma once

#include "geometry/mesh.h"

namespace relight {

// Octahedron subdivided `levels` times, projected onto the unit sphere (4^levels * 8 faces).
TriangleMesh MakeIcosphere(int levels);
// Axis-aligned box with outward faces.
TriangleMesh MakeBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);
// A grid of (nx+1)×(ny+1) vertices over [x0,x1]×[y0,y1] at height z, normals +Z.
TriangleMesh MakeGrid(float x0, float x1, float y0, float y1, float z, int nx, int ny);

}  // namespace relight
