#include "geometry/mesh_io.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

PlyType ParsePlyType(const std::string& t, const std::string& file) {
  if (t == "char" || t == "int8") return PlyType::kInt8;
  if (t == "uchar" || t == "uint8") return PlyType::kUint8;
  if (t == "short" || t == "int16") return PlyType::kInt16;
  if (t == "ushort" || t == "uint16") return PlyType::kUint16;
  if (t == "int" || t == "int32") return PlyType::kInt32;
  if (t == "uint" || t == "uint32") return PlyType::kUint32;
  if (t == "float" || t == "float32") return PlyType::kFloat32;
  if (t == "double" || t == "float64") return PlyType::kFloat64;
  RELIGHT_USER_ERROR() << "'" << file << "': unknown PLY property type '" << t << "'";
}

int TypeSize(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8: return 1;
    case PlyType::kInt16:
    case PlyType::kUint16: return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

// Reads scalars from the body in the file's format.
class PlyBodyReader {
 public:
  PlyBodyReader(std::istream& in, PlyFormat format, std::string file)
      : in_(in), format_(format), file_(std::move(file)) {}

  double Read(PlyType t) {
    if (format_ == PlyFormat::kAscii) {
      double v;
      if (!(in_ >> v)) Damaged();
      return v;
    }
    unsigned char buf[8];
    const int n = TypeSize(t);
    in_.read(reinterpret_cast<char*>(buf), n);
    if (!in_) Damaged();
    if (format_ == PlyFormat::kBinaryBig) std::reverse(buf, buf + n);
    switch (t) {
      case PlyType::kInt8: return static_cast<int8_t>(buf[0]);
      case PlyType::kUint8: return buf[0];
      case PlyType::kInt16: { int16_t v; std::memcpy(&v, buf, 2); return v; }
      case PlyType::kUint16: { uint16_t v; std::memcpy(&v, buf, 2); return v; }
      case PlyType::kInt32: { int32_t v; std::memcpy(&v, buf, 4); return v; }
      case PlyType::kUint32: { uint32_t v; std::memcpy(&v, buf, 4); return v; }
      case PlyType::kFloat32: { float v; std::memcpy(&v, buf, 4); return v; }
      case PlyType::kFloat64: { double v; std::memcpy(&v, buf, 8); return v; }
    }
    return 0;
  }

  // A list count or vertex index: an integer in int's range, else the file is damaged.
  int ReadInt(PlyType t) {
    const double v = Read(t);
    if (!(v >= INT_MIN && v <= INT_MAX)) Damaged();
    return static_cast<int>(v);
  }

  [[noreturn]] void Damaged() {
    RELIGHT_USER_ERROR() << "'" << file_ << "' ends early or holds invalid numbers; the mesh file is damaged";
  }

 private:
  std::istream& in_;
  PlyFormat format_;
  std::string file_;
};

void AddFan(const std::vector<int>& poly, std::vector<Eigen::Vector3i>* faces) {
  for (size_t k = 1; k + 1 < poly.size(); ++k) faces->emplace_back(poly[0], poly[k], poly[k + 1]);
}

TriangleMesh ReadPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) RELIGHT_USER_ERROR() << "cannot read mesh '" << path << "'";
  std::string line;
  std::getline(in, line);
  if (line.rfind("ply", 0) != 0) RELIGHT_USER_ERROR() << "'" << path << "' is not a PLY file (no 'ply' header)";
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  bool header_done = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream s(line);
    std::string word;
    s >> word;
    if (word == "format") {
      std::string f;
      s >> f;
      if (f == "ascii") format = PlyFormat::kAscii;
      else if (f == "binary_little_endian") format = PlyFormat::kBinaryLittle;
      else if (f == "binary_big_endian") format = PlyFormat::kBinaryBig;
      else RELIGHT_USER_ERROR() << "'" << path << "': unknown PLY format '" << f << "'";
    } else if (word == "element") {
      PlyElement e;
      s >> e.name >> e.count;
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) RELIGHT_USER_ERROR() << "'" << path << "': property before any element";
      PlyProperty p;
      std::string type;
      s >> type;
      if (type == "list") {
        std::string count_type, item_type;
        s >> count_type >> item_type >> p.name;
        p.is_list = true;
        p.count_type = ParsePlyType(count_type, path);
        p.type = ParsePlyType(item_type, path);
      } else {
        p.type = ParsePlyType(type, path);
        s >> p.name;
      }
      elements.back().properties.push_back(p);
    } else if (word == "end_header") {
      header_done = true;
      break;
    }
  }
  if (!header_done) RELIGHT_USER_ERROR() << "'" << path << "': PLY header has no end_header";

  // Counts come from the header: each item takes at least one byte per property (binary: the property's size;
  // ASCII: a digit), so a count the rest of the file cannot hold is damage, found before anything is allocated.
  const std::streamoff body_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff body_bytes = std::max<std::streamoff>(0, in.tellg() - body_start);
  in.seekg(body_start);
  for (const PlyElement& e : elements) {
    size_t item_bytes = 0;
    for (const PlyProperty& p : e.properties) {
      item_bytes += format == PlyFormat::kAscii ? 2 : TypeSize(p.is_list ? p.count_type : p.type);
    }
    if (e.count > static_cast<size_t>(body_bytes) / std::max<size_t>(1, item_bytes)) {
      RELIGHT_USER_ERROR() << "'" << path << "': the header claims " << e.count << " " << e.name
                           << " items, more than the file's " << body_bytes << " bytes of data hold; the mesh file is "
                           << "damaged";
    }
  }

  TriangleMesh mesh;
  PlyBodyReader reader(in, format, path);
  for (const PlyElement& e : elements) {
    if (e.name == "vertex") {
      mesh.vertices.resize(e.count);
      int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, ir = -1, ig = -1, ib = -1;
      std::vector<int> extra;  // property index -> mesh property slot, or -1
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const std::string& n = e.properties[k].name;
        const int kk = static_cast<int>(k);
        if (n == "x") ix = kk;
        else if (n == "y") iy = kk;
        else if (n == "z") iz = kk;
        else if (n == "nx") inx = kk;
        else if (n == "ny") iny = kk;
        else if (n == "nz") inz = kk;
        else if (n == "red" || n == "r") ir = kk;
        else if (n == "green" || n == "g") ig = kk;
        else if (n == "blue" || n == "b") ib = kk;
      }
      if (ix < 0 || iy < 0 || iz < 0) RELIGHT_USER_ERROR() << "'" << path << "': vertices lack x, y or z";
      const bool has_normals = inx >= 0 && iny >= 0 && inz >= 0;
      const bool has_colors = ir >= 0 && ig >= 0 && ib >= 0;
      if (has_normals) mesh.normals.resize(e.count);
      if (has_colors) mesh.colors.resize(e.count);
      std::vector<int> slot(e.properties.size(), -1);
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const int kk = static_cast<int>(k);
        if (kk == ix || kk == iy || kk == iz || kk == inx || kk == iny || kk == inz || kk == ir || kk == ig ||
            kk == ib || e.properties[k].is_list || e.properties[k].name == "alpha") {
          continue;
        }
        slot[k] = static_cast<int>(mesh.properties.size());
        mesh.properties.emplace_back(e.properties[k].name, std::vector<float>(e.count));
      }
      std::vector<double> values(e.properties.size());
      for (size_t v = 0; v < e.count; ++v) {
        for (size_t k = 0; k < e.properties.size(); ++k) {
          const PlyProperty& p = e.properties[k];
          if (p.is_list) {
            const int n = reader.ReadInt(p.count_type);
            for (int q = 0; q < n; ++q) reader.Read(p.type);
            continue;
          }
          values[k] = reader.Read(p.type);
        }
        mesh.vertices[v] = Eigen::Vector3f(values[ix], values[iy], values[iz]);
        if (has_normals) mesh.normals[v] = Eigen::Vector3f(values[inx], values[iny], values[inz]);
        if (has_colors) {
          const bool is_float = e.properties[ir].type == PlyType::kFloat32 || e.properties[ir].type == PlyType::kFloat64;
          const double s = is_float ? 255.0 : 1.0;
          for (int c = 0; c < 3; ++c) {
            const double x = values[c == 0 ? ir : c == 1 ? ig : ib] * s;
            mesh.colors[v][c] =
                std::isfinite(x) ? static_cast<uint8_t>(std::clamp(x + (is_float ? 0.5 : 0.0), 0.0, 255.0)) : 0;
          }
        }
        for (size_t k = 0; k < e.properties.size(); ++k) {
          if (slot[k] >= 0) mesh.properties[slot[k]].second[v] = static_cast<float>(values[k]);
        }
      }
    } else if (e.name == "face") {
      int list_index = -1;
      for (size_t k = 0; k < e.properties.size(); ++k) {
        if (e.properties[k].is_list &&
            (e.properties[k].name == "vertex_indices" || e.properties[k].name == "vertex_index")) {
          list_index = static_cast<int>(k);
        }
      }
      if (list_index < 0) RELIGHT_USER_ERROR() << "'" << path << "': faces lack a vertex_indices list";
      mesh.faces.reserve(e.count);
      std::vector<int> poly;
      for (size_t f = 0; f < e.count; ++f) {
        for (size_t k = 0; k < e.properties.size(); ++k) {
          const PlyProperty& p = e.properties[k];
          if (!p.is_list) {
            reader.Read(p.type);
            continue;
          }
          const int n = reader.ReadInt(p.count_type);
          if (n < 0 || n > 1000) reader.Damaged();
          poly.resize(n);
          for (int q = 0; q < n; ++q) poly[q] = reader.ReadInt(p.type);
          if (static_cast<int>(k) == list_index) AddFan(poly, &mesh.faces);
        }
      }
    } else {
      // Skip other elements (edges, materials, ...).
      for (size_t i = 0; i < e.count; ++i) {
        for (const auto& p : e.properties) {
          if (p.is_list) {
            const int n = reader.ReadInt(p.count_type);
            for (int q = 0; q < n; ++q) reader.Read(p.type);
          } else {
            reader.Read(p.type);
          }
        }
      }
    }
  }
  return mesh;
}

int ObjIndex(const std::string& token, int num_vertices, const std::string& path) {
  const std::string first = token.substr(0, token.find('/'));
  int i = 0;
  try {
    i = std::stoi(first);
  } catch (const std::exception&) {
    RELIGHT_USER_ERROR() << "'" << path << "': bad face index '" << token << "'";
  }
  return i < 0 ? num_vertices + i : i - 1;
}

TriangleMesh ReadObj(const std::string& path) {
  std::ifstream in(path);
  if (!in) RELIGHT_USER_ERROR() << "cannot read mesh '" << path << "'";
  TriangleMesh mesh;
  std::string line;
  std::vector<int> poly;
  bool any_color = false;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      double x, y, z;
      if (!(s >> x >> y >> z)) RELIGHT_USER_ERROR() << "'" << path << "': bad vertex line '" << line << "'";
      mesh.vertices.emplace_back(x, y, z);
      double r, g, b;
      if (s >> r >> g >> b) {
        any_color = true;
        mesh.colors.resize(mesh.vertices.size() - 1);
        mesh.colors.push_back(Eigen::Matrix<uint8_t, 3, 1>(static_cast<uint8_t>(std::clamp(r * 255 + 0.5, 0.0, 255.0)),
                                                            static_cast<uint8_t>(std::clamp(g * 255 + 0.5, 0.0, 255.0)),
                                                            static_cast<uint8_t>(std::clamp(b * 255 + 0.5, 0.0, 255.0))));
      }
    } else if (tag == "f") {
      poly.clear();
      std::string token;
      while (s >> token) poly.push_back(ObjIndex(token, static_cast<int>(mesh.vertices.size()), path));
      AddFan(poly, &mesh.faces);
    }
  }
  if (any_color) mesh.colors.resize(mesh.vertices.size());
  return mesh;
}

TriangleMesh ReadOff(const std::string& path) {
  std::ifstream in(path);
  if (!in) RELIGHT_USER_ERROR() << "cannot read mesh '" << path << "'";
  // Tokens without comments.
  std::vector<std::string> tokens;
  std::string line;
  while (std::getline(in, line)) {
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream s(line);
    std::string t;
    while (s >> t) tokens.push_back(t);
  }
  size_t pos = 0;
  if (tokens.empty() || tokens[0].find("OFF") == std::string::npos) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not an OFF file (no OFF header)";
  }
  const bool colored = tokens[0].find('C') != std::string::npos;
  const bool with_normals = tokens[0].find('N') != std::string::npos;
  ++pos;
  auto next = [&]() -> double {
    if (pos >= tokens.size()) RELIGHT_USER_ERROR() << "'" << path << "' ends early; the mesh file is damaged";
    const std::string& token = tokens[pos++];
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0' || !std::isfinite(v)) {
      RELIGHT_USER_ERROR() << "'" << path << "': '" << token.substr(0, 40) << "' is not a finite number; the mesh "
                           << "file is damaged";
    }
    return v;
  };
  // A count or index: an integer no larger than what the remaining tokens can hold (checked before allocating).
  auto next_count = [&](size_t per_item) -> int {
    const double v = next();
    const double most = double(tokens.size() - pos) / double(per_item);
    if (!(v >= 0 && v <= most && v == std::floor(v))) {
      RELIGHT_USER_ERROR() << "'" << path << "': count " << v << " does not fit the file; the mesh file is damaged";
    }
    return static_cast<int>(v);
  };
  auto next_index = [&]() -> int {
    const double v = next();
    if (!(v >= INT_MIN && v <= INT_MAX)) {
      RELIGHT_USER_ERROR() << "'" << path << "': index " << v << " is out of range; the mesh file is damaged";
    }
    return static_cast<int>(v);
  };
  const int nv = next_count(3), nf = next_count(1);
  next();  // edges
  TriangleMesh mesh;
  mesh.vertices.resize(nv);
  for (int i = 0; i < nv; ++i) {
    const double x = next(), y = next(), z = next();
    mesh.vertices[i] = Eigen::Vector3f(x, y, z);
    if (with_normals) next(), next(), next();
    if (colored) next(), next(), next(), next();
  }
  std::vector<int> poly;
  for (int i = 0; i < nf; ++i) {
    const int n = next_count(1);
    poly.resize(n);
    for (int k = 0; k < n; ++k) poly[k] = next_index();
    AddFan(poly, &mesh.faces);
    // Optional per-face colour tokens up to the end of the line are not separable
    // after tokenising; OFF files with face colours are rare for scans and are not supported.
  }
  return mesh;
}

}  // namespace

TriangleMesh ReadMesh(const std::string& path) {
  if (!fs::is_regular_file(path)) RELIGHT_USER_ERROR() << "mesh file '" << path << "' does not exist";
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  TriangleMesh mesh;
  if (ext == ".ply") {
    mesh = ReadPly(path);
  } else if (ext == ".obj") {
    mesh = ReadObj(path);
  } else if (ext == ".off") {
    mesh = ReadOff(path);
  } else {
    RELIGHT_USER_ERROR() << "mesh '" << path << "' has an unsupported format; use .ply, .obj or .off";
  }
  mesh.Check(path);
  return mesh;
}

void WriteMeshPly(const std::string& path, const TriangleMesh& mesh, bool binary) {
  mesh.Check(path);
  const bool has_normals = mesh.normals.size() == mesh.vertices.size() && !mesh.vertices.empty();
  const bool has_colors = mesh.colors.size() == mesh.vertices.size() && !mesh.vertices.empty();
  std::ostringstream header;
  header << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment written by relight\n"
         << "element vertex " << mesh.vertices.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (has_normals) header << "property float nx\nproperty float ny\nproperty float nz\n";
  if (has_colors) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const auto& [name, values] : mesh.properties) header << "property float " << name << "\n";
  header << "element face " << mesh.faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  std::string out = header.str();
  if (binary) {
    auto put = [&out](const void* p, size_t n) { out.append(static_cast<const char*>(p), n); };
    out.reserve(out.size() + mesh.vertices.size() * (12 + 12 + 3 + 4 * mesh.properties.size()) + mesh.faces.size() * 13);
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      put(mesh.vertices[i].data(), 12);
      if (has_normals) put(mesh.normals[i].data(), 12);
      if (has_colors) put(mesh.colors[i].data(), 3);
      for (const auto& [name, values] : mesh.properties) put(&values[i], 4);
    }
    for (const auto& f : mesh.faces) {
      const uint8_t n = 3;
      put(&n, 1);
      const int32_t idx[3] = {f[0], f[1], f[2]};
      put(idx, 12);
    }
  } else {
    std::ostringstream s;
    s.precision(9);
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      s << mesh.vertices[i].x() << " " << mesh.vertices[i].y() << " " << mesh.vertices[i].z();
      if (has_normals) s << " " << mesh.normals[i].x() << " " << mesh.normals[i].y() << " " << mesh.normals[i].z();
      if (has_colors) s << " " << int(mesh.colors[i][0]) << " " << int(mesh.colors[i][1]) << " " << int(mesh.colors[i][2]);
      for (const auto& [name, values] : mesh.properties) s << " " << values[i];
      s << "\n";
    }
    for (const auto& f : mesh.faces) s << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n";
    out += s.str();
  }
  WriteFileAtomic(path, out);
}

}  // namespace relight
