#include "geometry/mesh_io.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/fs.h"
#include "testing/testing.h"

namespace relight {
namespace {

TriangleMesh Tetrahedron() {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  m.ComputeVertexNormals();
  m.colors = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {10, 20, 30}};
  m.Property("albedo_r") = {0.1f, 0.2f, 0.3f, 0.4f};
  m.Property("w0") = {1, 0, 0.5f, 0.25f};
  return m;
}

void ExpectSame(const TriangleMesh& a, const TriangleMesh& b) {
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.faces.size(), b.faces.size());
  for (size_t i = 0; i < a.vertices.size(); ++i) EXPECT_TRUE(a.vertices[i].isApprox(b.vertices[i], 1e-6f));
  for (size_t i = 0; i < a.faces.size(); ++i) EXPECT_EQ(a.faces[i], b.faces[i]);
  ASSERT_EQ(a.normals.size(), b.normals.size());
  for (size_t i = 0; i < a.normals.size(); ++i) EXPECT_TRUE(a.normals[i].isApprox(b.normals[i], 1e-6f));
  EXPECT_EQ(a.colors, b.colors);
  ASSERT_EQ(a.properties.size(), b.properties.size());
  for (size_t k = 0; k < a.properties.size(); ++k) {
    EXPECT_EQ(a.properties[k].first, b.properties[k].first);
    for (size_t i = 0; i < a.vertices.size(); ++i)
      EXPECT_NEAR(a.properties[k].second[i], b.properties[k].second[i], 1e-6);
  }
}

TEST(MeshIoTest, PlyRoundTripBinaryAndAscii) {
  testing::TempDir dir;
  const TriangleMesh m = Tetrahedron();
  WriteMeshPly(dir / "b.ply", m, true);
  WriteMeshPly(dir / "a.ply", m, false);
  ExpectSame(m, ReadMesh(dir / "b.ply"));
  ExpectSame(m, ReadMesh(dir / "a.ply"));
}

TEST(MeshIoTest, ObjOffAndPolygonsAndBigEndianPly) {
  testing::TempDir dir;
  WriteFileAtomic(dir / "q.obj", "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -2 -1\n");
  const TriangleMesh obj = ReadMesh(dir / "q.obj");
  EXPECT_EQ(obj.num_vertices(), 4u);
  ASSERT_EQ(obj.num_faces(), 3u);
  EXPECT_EQ(obj.faces[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(obj.faces[2], Eigen::Vector3i(0, 2, 3));
  WriteFileAtomic(dir / "t.off", "OFF\n# comment\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  EXPECT_EQ(ReadMesh(dir / "t.off").num_faces(), 2u);
  // A big-endian binary PLY with a double vertex property.
  std::string ply = "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                    "property double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  auto put_be = [&ply](const void* p, size_t n) {
    const char* c = static_cast<const char*>(p);
    for (size_t i = 0; i < n; ++i) ply.push_back(c[n - 1 - i]);
  };
  for (double v : {0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0, 0.0}) put_be(&v, 8);
  ply.push_back(3);
  for (uint32_t i : {0u, 1u, 2u}) put_be(&i, 4);
  WriteFileAtomic(dir / "be.ply", ply);
  const TriangleMesh be = ReadMesh(dir / "be.ply");
  EXPECT_TRUE(be.vertices[2].isApprox(Eigen::Vector3f(0, 3, 0)));
  EXPECT_NEAR(be.SurfaceArea(), 3.0, 1e-6);
}

TEST(MeshIoTest, StanfordBunnyLoads) {
  const std::string path = testing::SharedDataDir() + "/meshes/stanford-bunny.obj";
  ASSERT_TRUE(testing::HasSharedData("meshes/stanford-bunny.obj")) << path;
  const TriangleMesh bunny = ReadMesh(path);
  EXPECT_EQ(bunny.num_vertices(), 35947u);
  EXPECT_GT(bunny.num_faces(), 69000u);
}

TEST(MeshIoTest, DamagedFilesAreUserErrors) {
  testing::TempDir dir;
  const TriangleMesh m = Tetrahedron();
  WriteMeshPly(dir / "b.ply", m, true);
  const std::string bytes = ReadFileToString(dir / "b.ply");
  WriteFileAtomic(dir / "cut.ply", bytes.substr(0, bytes.size() - 20));
  EXPECT_THROW(ReadMesh(dir / "cut.ply"), UserError);
  WriteFileAtomic(dir / "bad.obj", "v 0 0 0\nf 1 2 3\n");
  EXPECT_THROW(ReadMesh(dir / "bad.obj"), UserError);  // index out of range
  WriteFileAtomic(dir / "x.stl", "solid");
  EXPECT_THROW(ReadMesh(dir / "x.stl"), UserError);
  EXPECT_THROW(ReadMesh(dir / "none.ply"), UserError);
}

TEST(MeshTest, NormalsAreaAndAppend) {
  TriangleMesh m = Tetrahedron();
  EXPECT_NEAR(m.SurfaceArea(), 1.5 + std::sqrt(3.0) / 2, 1e-6);
  // The apex (0,0,1) touches faces with normals -y, -x (corner angle 45° each) and
  // (1,1,1)/√3 (60°): the angle-weighted normal is their weighted sum.
  const Eigen::Vector3f expected = (M_PI / 4 * Eigen::Vector3f(0, -1, 0) + M_PI / 4 * Eigen::Vector3f(-1, 0, 0) +
                                    M_PI / 3 * Eigen::Vector3f(1, 1, 1).normalized())
                                       .normalized();
  EXPECT_TRUE(m.normals[3].isApprox(expected, 1e-5f));
  TriangleMesh other = Tetrahedron();
  other.properties.clear();
  other.Property("extra") = {1, 1, 1, 1};
  m.Append(other);
  EXPECT_EQ(m.num_vertices(), 8u);
  EXPECT_EQ(m.faces[4], Eigen::Vector3i(4, 6, 5));
  EXPECT_EQ((*m.FindProperty("w0"))[4], 0.0f);
  EXPECT_EQ((*m.FindProperty("extra"))[0], 0.0f);
  EXPECT_EQ((*m.FindProperty("extra"))[7], 1.0f);
  m.Check("appended");
}

}  // namespace
}  // namespace relight
