// Mesh files: PLY (ASCII and binary, any scalar vertex properties), OBJ and OFF.
//
// Written by hand: the stack's readers (CGAL, assimp) either drop named
// per-vertex properties (material weights, albedo) that stages exchange, or
// reject the non-manifold meshes that the mesh stage exists to repair.
#pragma once

#include <string>

#include "geometry/mesh.h"

namespace relight {

// Reads .ply, .obj or .off (by extension). Polygons are fan-triangulated.
// Throws UserError naming the file for missing, unsupported or damaged files.
TriangleMesh ReadMesh(const std::string& path);

// Writes a PLY file atomically: x y z, nx ny nz (if normals), red green blue
// (if colours), every named property as float, faces as uchar-count int lists.
void WriteMeshPly(const std::string& path, const TriangleMesh& mesh, bool binary = true);

}  // namespace relight
