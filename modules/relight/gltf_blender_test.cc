// The glTF export imported by Blender (Debian `blender`; tools/setup_debian.sh installs it): the test writes
// the test model's model.glb, imports it with `bpy.ops.import_scene.gltf` in a background Blender and
// compares what Blender built with the mesh: triangles and loops, vertices (Blender splits them per
// primitive), the world-frame (+Z up) positions (Blender undoes glTF's +Y up), the mean of the imported
// colour attribute and each material's roughness; and an exported environment map as Blender's world light
// through the node set-up docs/FORMATS.md gives. Fails, saying what to install, when blender is missing.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "core/fs.h"
#include "core/json.h"
#include "relight/gltf_export.h"
#include "relight/gltf_test_model.h"
#include "sphere/octahedral.h"
#include "testing/testing.h"

namespace relight {
namespace {

// Imports argv[0] (.glb) into an empty scene and writes what Blender made of it to argv[1] (JSON). argv[2]:
// "normals", the importer's default shading (Use Normal Data), with the numpy.bool alias restored first:
// Debian 12's Blender 3.4.1 importer still uses it and NumPy 1.24 removed it (KhronosGroup/glTF-Blender-IO
// #1844, fixed in Blender 3.5), the workaround docs/FORMATS.md gives; "smooth": Shading = Smooth, which
// avoids that code.
constexpr char kImportScript[] = R"(import bpy, json, sys, numpy
glb, out_path, mode = sys.argv[sys.argv.index("--") + 1:][:3]
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o, do_unlink=True)
if mode == "normals":
    if not hasattr(numpy, "bool"):
        numpy.bool = bool
    bpy.ops.import_scene.gltf(filepath=glb)
else:
    bpy.ops.import_scene.gltf(filepath=glb, import_shading="SMOOTH")
meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
out = {"objects": len(meshes), "vertices": 0, "loops": 0, "polygons": 0, "colors": [], "materials": {}}
positions = set()
lo, hi = [float("inf")] * 3, [-float("inf")] * 3
for o in meshes:
    me = o.data
    out["vertices"] += len(me.vertices)
    out["loops"] += len(me.loops)
    out["polygons"] += len(me.polygons)
    for v in me.vertices:
        p = o.matrix_world @ v.co
        positions.add(tuple(round(c, 5) for c in p))
        lo = [min(a, b) for a, b in zip(lo, p)]
        hi = [max(a, b) for a, b in zip(hi, p)]
    for attr in me.color_attributes:
        total, n = [0.0] * 4, 0
        for d in attr.data:
            total = [t + c for t, c in zip(total, d.color)]
            n += 1
        out["colors"].append({"name": attr.name, "domain": attr.domain, "data_type": attr.data_type,
                              "count": n, "mean": [t / max(n, 1) for t in total]})
    for slot in o.material_slots:
        m = slot.material
        bsdf = [n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"] if m and m.use_nodes else []
        if bsdf:
            out["materials"][m.name] = {"roughness": bsdf[0].inputs["Roughness"].default_value,
                                        "metallic": bsdf[0].inputs["Metallic"].default_value}
out["distinct_positions"] = len(positions)
out["min"], out["max"] = lo, hi
with open(out_path, "w") as f:
    json.dump(out, f)
)";

// Renders (Cycles, 4 x 4 px, 10 deg field of view) the world lit by the lat-long map argv[0] through the node
// set-up docs/FORMATS.md gives (Texture Coordinate "Generated" -> Mapping, vector, scale (-1, 1, 1) ->
// Environment Texture -> Background), looking along the six axes; writes the mean of the centre 2 x 2 pixels
// per axis to argv[1] (JSON).
constexpr char kWorldScript[] = R"(import bpy, json, math, sys
import numpy as np
exr, out_path = sys.argv[sys.argv.index("--") + 1:][:2]
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o, do_unlink=True)
sc = bpy.context.scene
sc.world = bpy.data.worlds.new("export")
sc.world.use_nodes = True
nt = sc.world.node_tree
env = nt.nodes.new("ShaderNodeTexEnvironment")
env.image = bpy.data.images.load(exr)
coords = nt.nodes.new("ShaderNodeTexCoord")
mapping = nt.nodes.new("ShaderNodeMapping")
mapping.vector_type = "VECTOR"
mapping.inputs["Scale"].default_value = (-1, 1, 1)
nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
cam.data.lens = 200
sc.collection.objects.link(cam)
sc.camera = cam
sc.render.engine = "CYCLES"
sc.cycles.samples = 4
sc.cycles.use_denoising = False
sc.view_layers[0].cycles.use_denoising = False
sc.render.resolution_x = sc.render.resolution_y = 4
sc.render.resolution_percentage = 100
sc.view_settings.view_transform = "Standard"
sc.render.image_settings.file_format = "OPEN_EXR"
out = {}
# Blender cameras look along their -Z: these Euler angles (deg) turn it to each axis.
for name, rot in [("+X", (90, 0, -90)), ("-X", (90, 0, 90)), ("+Y", (90, 0, 0)), ("-Y", (90, 0, 180)),
                  ("+Z", (180, 0, 0)), ("-Z", (0, 0, 0))]:
    cam.rotation_euler = [math.radians(a) for a in rot]
    sc.render.filepath = out_path + ".render.exr"
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(sc.render.filepath, check_existing=False)
    p = np.array(image.pixels[:]).reshape(4, 4, 4)
    out[name] = [float(c) for c in p[1:3, 1:3, :3].mean(axis=(0, 1))]
with open(out_path, "w") as f:
    json.dump(out, f)
)";

// Blender's round trip of a linear value through an 8-bit sRGB colour (BYTE_COLOR attributes).
double ThroughSrgbByte(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  const double s = c < 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055;
  const double byte = std::floor(s * 255 + 0.5) / 255;
  return byte <= 0.04045 ? byte / 12.92 : std::pow((byte + 0.055) / 1.055, 2.4);
}

// Runs the import script in a background Blender; returns its result.
Json ImportInBlender(const testing::TempDir& dir, const std::string& glb, const std::string& mode) {
  WriteFileAtomic(dir / "import.py", kImportScript);
  const std::string out = dir / ("result_" + mode + ".json");
  std::string log;
  const int rc = testing::RunCommand("timeout 240 blender -b --factory-startup --python-exit-code 1 --python " +
                                         (dir / "import.py") + " -- " + glb + " " + out + " " + mode,
                                     &log);
  EXPECT_EQ(rc, 0) << log;
  return rc == 0 ? ReadJsonFile(out) : Json();
}

class GltfBlender : public ::testing::TestWithParam<std::string> {};

TEST_P(GltfBlender, BlenderImportsTheModelWithItsFrameColoursAndMaterials) {
  ASSERT_EQ(testing::RunCommand("command -v blender > /dev/null"), 0)
      << "blender is not installed: run tools/setup_debian.sh (Debian package blender); this test imports the glTF "
         "export into Blender";
  const gltf_testing::TestModel t = gltf_testing::MakeTestModel();
  const TriangleMesh& mesh = t.mesh;
  testing::TempDir dir;
  const GltfModelSummary s = WriteModelGlb(dir / "model.glb", mesh, t.reflectance);
  const Json r = ImportInBlender(dir, dir / "model.glb", GetParam());
  ASSERT_TRUE(r.is_object());
  RecordProperty("blender", r.dump());

  // Triangles and corners; Blender makes one vertex per distinct index of each primitive.
  const std::vector<int> dominant = DominantFaceMaterials(mesh, int(t.reflectance.materials.size()));
  std::vector<std::set<int>> used(t.reflectance.materials.size());
  for (size_t f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) used[dominant[f]].insert(mesh.faces[f][c]);
  size_t split_vertices = 0;
  for (const auto& u : used) split_vertices += u.size();
  EXPECT_EQ(r["objects"], 1);
  EXPECT_EQ(r["polygons"].get<size_t>(), mesh.num_faces());
  EXPECT_EQ(r["loops"].get<size_t>(), 3 * mesh.num_faces());
  EXPECT_EQ(r["vertices"].get<size_t>(), split_vertices);
  EXPECT_EQ(r["distinct_positions"].get<size_t>(), mesh.num_vertices());
  // Blender is +Z up like the project: its bounding box is the mesh's world-frame box.
  const Eigen::AlignedBox3f box = mesh.BoundingBox();
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(r["min"][c].get<double>(), box.min()[c], 1e-5) << "axis " << c;
    EXPECT_NEAR(r["max"][c].get<double>(), box.max()[c], 1e-5) << "axis " << c;
  }

  // The colour attribute: mean over face corners of COLOR_0 (8-bit sRGB when Blender stores bytes).
  ASSERT_EQ(r["colors"].size(), 1u) << r.dump();
  const Json& color = r["colors"][0];
  EXPECT_EQ(color["domain"], "CORNER");
  EXPECT_EQ(color["count"].get<size_t>(), 3 * mesh.num_faces());
  const bool bytes = color["data_type"] == "BYTE_COLOR";
  const std::vector<Eigen::Vector3f> albedo = VertexAlbedo(mesh, t.reflectance);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), mean_exact = Eigen::Vector3d::Zero();
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) {
        const double a = std::clamp(double(albedo[f[k]][c]), 0.0, 1.0);
        mean[c] += bytes ? ThroughSrgbByte(a) : a;
        mean_exact[c] += a;
      }
  mean /= 3.0 * mesh.num_faces();
  mean_exact /= 3.0 * mesh.num_faces();
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(color["mean"][c].get<double>(), mean[c], 1e-3) << "channel " << c << ", " << color.dump();
    EXPECT_NEAR(color["mean"][c].get<double>(), mean_exact[c], 5e-3) << "channel " << c;
  }
  EXPECT_NEAR(color["mean"][3].get<double>(), 1.0, 1e-6);

  // The materials of the used primitives, with the exported roughness and no metal.
  EXPECT_EQ(r["materials"].size(), size_t(s.primitives)) << r["materials"].dump();
  for (size_t m = 0; m < t.reflectance.materials.size(); ++m) {
    const std::string& name = t.reflectance.materials[m].name;
    if (used[m].empty()) {
      EXPECT_FALSE(r["materials"].contains(name)) << name;
      continue;
    }
    ASSERT_TRUE(r["materials"].contains(name)) << name << " in " << r["materials"].dump();
    EXPECT_NEAR(r["materials"][name]["roughness"].get<double>(), s.roughness[m], 1e-6) << name;
    EXPECT_EQ(r["materials"][name]["metallic"].get<double>(), 0.0) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Shading, GltfBlender, ::testing::Values("normals", "smooth"));

// An exported environment map lights Blender's world as the project's convention says, through the documented
// mapping (Blender's lat-long is the mirror image of the project's: without the scale -1 on X, +X and -X swap).
TEST(GltfBlenderWorld, ExportedMapLightsTheWorldInTheWorldFrame) {
  ASSERT_EQ(testing::RunCommand("command -v blender > /dev/null"), 0)
      << "blender is not installed: run tools/setup_debian.sh (Debian package blender)";
  // A map whose radiance in direction d is max(0, d) per channel (R: +X, G: +Y, B: +Z), written by the export.
  const int n = 32;
  Image oct(n, n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d d = OctTexelDirection(i, j, n);
      for (int c = 0; c < 3; ++c) oct.at(i, j, c) = float(std::max(0.0, d[c]));
    }
  const gltf_testing::TestModel t = gltf_testing::MakeTestModel();
  testing::TempDir dir;
  RecoveredPhoto photo;
  photo.name = "photo.jpg";
  photo.envmap = EnvMap::FromOctahedral(oct);
  const ExportRecord e = WriteExport(dir.path(), t.mesh, t.reflectance, {photo});
  ASSERT_EQ(e.albedo_scale, 1.0);
  ASSERT_EQ(e.envmaps.size(), 1u);
  WriteFileAtomic(dir / "world.py", kWorldScript);
  std::string log;
  const int rc =
      testing::RunCommand("timeout 240 blender -b --factory-startup --python-exit-code 1 --python " +
                              (dir / "world.py") + " -- " + (dir / e.envmaps[0]) + " " + (dir / "world.json"),
                          &log);
  ASSERT_EQ(rc, 0) << log;
  const Json r = ReadJsonFile(dir / "world.json");
  RecordProperty("blender_world", r.dump());
  const std::map<std::string, Eigen::Vector3d> axes = {
      {"+X", Eigen::Vector3d::UnitX()},  {"-X", -Eigen::Vector3d::UnitX()}, {"+Y", Eigen::Vector3d::UnitY()},
      {"-Y", -Eigen::Vector3d::UnitY()}, {"+Z", Eigen::Vector3d::UnitZ()},  {"-Z", -Eigen::Vector3d::UnitZ()}};
  for (const auto& [name, d] : axes) {
    ASSERT_TRUE(r.contains(name)) << r.dump();
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r[name][c].get<double>(), std::max(0.0, d[c]), 0.1) << "looking along " << name << ", channel " << c;
  }
}

}  // namespace
}  // namespace relight
