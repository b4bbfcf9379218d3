#include "geometry/reconstruction.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <locale>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"

namespace relight {
namespace fs = std::filesystem;

Eigen::Vector3d ImageRecord::ProjectionCenter() const {
  return -(CamFromWorldRotation().transpose() * cam_from_world_translation);
}

Eigen::Vector3d ImageRecord::ViewingDirection() const { return CamFromWorldRotation().row(2).transpose(); }

Eigen::Vector3d ImageRecord::CamFromWorld(const Eigen::Vector3d& p) const {
  return cam_from_world_rotation * p + cam_from_world_translation;
}

void ImageRecord::SetPose(const Eigen::Matrix3d& r, const Eigen::Vector3d& center) {
  cam_from_world_rotation = Eigen::Quaterniond(r).normalized();
  cam_from_world_translation = -(r * center);
}

Sim3 Sim3::Inverse() const {
  Sim3 inv;
  inv.scale = 1.0 / scale;
  inv.rotation = rotation.transpose();
  inv.translation = -(inv.scale * (inv.rotation * translation));
  return inv;
}

namespace {

// ---- binary helpers --------------------------------------------------------
// A COLMAP .bin file with its size, so that counts read from it can be checked
// against the bytes left before anything is allocated for them.
class BinaryFile {
 public:
  explicit BinaryFile(std::string path) : path_(std::move(path)), in_(path_, std::ios::binary) {
    if (!in_) RELIGHT_USER_ERROR() << "cannot read COLMAP model file '" << path_ << "'";
    in_.seekg(0, std::ios::end);
    size_ = static_cast<uint64_t>(std::max<std::streamoff>(0, in_.tellg()));
    in_.seekg(0, std::ios::beg);
  }
  template <typename T>
  T Read() {
    T v;
    in_.read(reinterpret_cast<char*>(&v), sizeof(T));
    if (!in_) Damaged("it ends early");
    return v;
  }
  // Throws unless `count` items of at least `bytes_each` bytes fit in what is left.
  void CheckCount(uint64_t count, uint64_t bytes_each, const char* what) {
    const uint64_t left = size_ - static_cast<uint64_t>(in_.tellg());
    if (count > left / bytes_each) {
      Damaged("it claims " + std::to_string(count) + " " + what + " but has " + std::to_string(left) + " bytes left");
    }
  }
  [[noreturn]] void Damaged(const std::string& why) {
    RELIGHT_USER_ERROR() << "'" << path_ << "' is not a valid COLMAP binary model file (" << why
                         << "); rerun the stage that wrote it, or give a model written by COLMAP";
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::ifstream in_;
  uint64_t size_ = 0;
};

template <typename T>
void WritePod(std::string* out, T v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}

std::ifstream OpenOrThrow(const std::string& path, bool binary) {
  std::ifstream in(path, binary ? std::ios::binary : std::ios::in);
  if (!in) RELIGHT_USER_ERROR() << "cannot read COLMAP model file '" << path << "'";
  return in;
}

// Next non-comment, non-empty line; counts lines read into `*number`.
bool NextLine(std::istream& in, std::string* line, int* number) {
  while (std::getline(in, *line)) {
    ++*number;
    const size_t b = line->find_first_not_of(" \t\r");
    if (b == std::string::npos || (*line)[b] == '#') continue;
    return true;
  }
  return false;
}

[[noreturn]] void BadLine(const std::string& file, int number, const std::string& line, const std::string& expected) {
  RELIGHT_USER_ERROR() << "'" << file << "' line " << number << " is not a COLMAP model line ('" << line.substr(0, 80)
                       << (line.size() > 80 ? "..." : "") << "'; expected " << expected
                       << "); give a model folder written by COLMAP";
}

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

Reconstruction Reconstruction::Read(const std::string& dir) {
  if (fs::exists(JoinPath(dir, "cameras.bin")) && fs::exists(JoinPath(dir, "images.bin"))) return ReadBinary(dir);
  if (fs::exists(JoinPath(dir, "cameras.txt")) && fs::exists(JoinPath(dir, "images.txt"))) return ReadText(dir);
  RELIGHT_USER_ERROR() << "'" << dir << "' holds no COLMAP model (cameras/images .bin or .txt)";
}

Reconstruction Reconstruction::ReadText(const std::string& dir) {
  Reconstruction r;
  {
    const std::string file = JoinPath(dir, "cameras.txt");
    const char* expected = "CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]";
    auto in = OpenOrThrow(file, false);
    std::string line;
    int number = 0;
    while (NextLine(in, &line, &number)) {
      std::istringstream s(line);
      s.imbue(std::locale::classic());
      Camera c;
      long long id = -1;
      if (!(s >> id >> c.model >> c.width >> c.height) || id < 0 || id > UINT32_MAX) {
        BadLine(file, number, line, expected);
      }
      c.camera_id = static_cast<uint32_t>(id);
      double p;
      while (s >> p) c.params.push_back(p);
      if (!s.eof()) BadLine(file, number, line, expected);  // something after the numbers
      c.Check(file + " line " + std::to_string(number));
      r.cameras[c.camera_id] = c;
    }
  }
  {
    const std::string file = JoinPath(dir, "images.txt");
    const char* expected = "IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then a line of POINTS2D[] as (X Y POINT3D_ID)";
    auto in = OpenOrThrow(file, false);
    std::string line;
    int number = 0;
    while (NextLine(in, &line, &number)) {
      std::istringstream s(line);
      s.imbue(std::locale::classic());
      ImageRecord im;
      double qw, qx, qy, qz;
      long long image_id = -1, camera_id = -1;
      if (!(s >> image_id >> qw >> qx >> qy >> qz >> im.cam_from_world_translation.x() >>
            im.cam_from_world_translation.y() >> im.cam_from_world_translation.z() >> camera_id) ||
          image_id < 0 || image_id > UINT32_MAX || camera_id < 0 || camera_id > UINT32_MAX) {
        BadLine(file, number, line, expected);
      }
      im.image_id = static_cast<uint32_t>(image_id);
      im.camera_id = static_cast<uint32_t>(camera_id);
      s >> std::ws;
      std::getline(s, im.name);  // names may contain spaces
      while (!im.name.empty() && (im.name.back() == '\r' || im.name.back() == ' ')) im.name.pop_back();
      const Eigen::Vector4d q(qw, qx, qy, qz);
      if (im.name.empty() || !q.allFinite() || !(q.norm() > 1e-12) || !Finite(im.cam_from_world_translation)) {
        BadLine(file, number, line, std::string(expected) + ", a non-zero finite rotation and a finite translation");
      }
      im.cam_from_world_rotation = Eigen::Quaterniond(qw, qx, qy, qz).normalized();
      // The points line follows (it may be empty, so read it raw).
      std::string points;
      if (std::getline(in, points)) {
        ++number;
        std::istringstream ps(points);
        ps.imbue(std::locale::classic());
        double x, y;
        long long id;
        while (ps >> x >> y >> id) {
          Point2D p;
          p.xy = {x, y};
          p.point3d_id = id < 0 ? Point2D::kInvalidPoint3D : static_cast<uint64_t>(id);
          im.points2d.push_back(p);
        }
      }
      if (!r.cameras.count(im.camera_id)) {
        RELIGHT_USER_ERROR() << "'" << file << "' line " << number << ": image '" << im.name
                             << "' uses camera " << im.camera_id << ", which cameras.txt does not list";
      }
      r.images[im.image_id] = im;
    }
  }
  const std::string points_file = JoinPath(dir, "points3D.txt");
  if (fs::exists(points_file)) {
    const char* expected = "POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID POINT2D_IDX)";
    auto in = OpenOrThrow(points_file, false);
    std::string line;
    int number = 0;
    while (NextLine(in, &line, &number)) {
      std::istringstream s(line);
      s.imbue(std::locale::classic());
      Point3D p;
      int rr, gg, bb;
      if (!(s >> p.point3d_id >> p.xyz.x() >> p.xyz.y() >> p.xyz.z() >> rr >> gg >> bb >> p.error) ||
          !Finite(p.xyz) || std::min({rr, gg, bb}) < 0 || std::max({rr, gg, bb}) > 255) {
        BadLine(points_file, number, line, expected);
      }
      p.rgb = {static_cast<uint8_t>(rr), static_cast<uint8_t>(gg), static_cast<uint8_t>(bb)};
      uint32_t image_id, idx;
      while (s >> image_id >> idx) p.track.emplace_back(image_id, idx);
      r.points3d[p.point3d_id] = p;
    }
  }
  return r;
}

Reconstruction Reconstruction::ReadBinary(const std::string& dir) {
  Reconstruction r;
  {
    BinaryFile in(JoinPath(dir, "cameras.bin"));
    const uint64_t n = in.Read<uint64_t>();
    in.CheckCount(n, 24, "cameras");
    for (uint64_t i = 0; i < n; ++i) {
      Camera c;
      c.camera_id = in.Read<uint32_t>();
      c.model = Camera::ModelName(in.Read<int32_t>());
      const uint64_t width = in.Read<uint64_t>(), height = in.Read<uint64_t>();
      if (width > INT32_MAX || height > INT32_MAX) in.Damaged("camera size " + std::to_string(width) + "x" + std::to_string(height));
      c.width = static_cast<int>(width);
      c.height = static_cast<int>(height);
      c.params.resize(Camera::NumParams(c.model));
      for (double& p : c.params) p = in.Read<double>();
      c.Check(in.path());
      r.cameras[c.camera_id] = c;
    }
  }
  {
    BinaryFile in(JoinPath(dir, "images.bin"));
    const uint64_t n = in.Read<uint64_t>();
    in.CheckCount(n, 73, "images");
    for (uint64_t i = 0; i < n; ++i) {
      ImageRecord im;
      im.image_id = in.Read<uint32_t>();
      double q[4], t[3];
      for (double& v : q) v = in.Read<double>();
      for (double& v : t) v = in.Read<double>();
      const Eigen::Vector4d qv(q[0], q[1], q[2], q[3]);
      im.cam_from_world_translation = {t[0], t[1], t[2]};
      if (!qv.allFinite() || !(qv.norm() > 1e-12) || !Finite(im.cam_from_world_translation)) {
        in.Damaged("image " + std::to_string(im.image_id) + " has a zero or non-finite pose");
      }
      im.cam_from_world_rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
      im.camera_id = in.Read<uint32_t>();
      char ch;
      while ((ch = in.Read<char>()) != '\0') im.name.push_back(ch);
      const uint64_t np = in.Read<uint64_t>();
      in.CheckCount(np, 24, "2D points");
      im.points2d.resize(np);
      for (auto& p : im.points2d) {
        p.xy.x() = in.Read<double>();
        p.xy.y() = in.Read<double>();
        p.point3d_id = in.Read<uint64_t>();
      }
      if (!r.cameras.count(im.camera_id)) {
        in.Damaged("image '" + im.name + "' uses camera " + std::to_string(im.camera_id) + ", which cameras.bin does not list");
      }
      r.images[im.image_id] = im;
    }
  }
  const std::string points_file = JoinPath(dir, "points3D.bin");
  if (fs::exists(points_file)) {
    BinaryFile in(points_file);
    const uint64_t n = in.Read<uint64_t>();
    in.CheckCount(n, 51, "3D points");
    for (uint64_t i = 0; i < n; ++i) {
      Point3D p;
      p.point3d_id = in.Read<uint64_t>();
      for (int k = 0; k < 3; ++k) p.xyz[k] = in.Read<double>();
      for (int k = 0; k < 3; ++k) p.rgb[k] = in.Read<uint8_t>();
      p.error = in.Read<double>();
      const uint64_t len = in.Read<uint64_t>();
      in.CheckCount(len, 8, "track entries");
      p.track.resize(len);
      for (auto& t : p.track) {
        t.first = in.Read<uint32_t>();
        t.second = in.Read<uint32_t>();
      }
      if (!Finite(p.xyz)) in.Damaged("point " + std::to_string(p.point3d_id) + " is not finite");
      r.points3d[p.point3d_id] = p;
    }
  }
  return r;
}

void Reconstruction::WriteText(const std::string& dir) const {
  std::ostringstream cams;
  cams << std::setprecision(17);
  cams << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
       << "# Number of cameras: " << cameras.size() << "\n";
  for (const auto& [id, c] : cameras) {
    cams << id << " " << c.model << " " << c.width << " " << c.height;
    for (double p : c.params) cams << " " << p;
    cams << "\n";
  }
  WriteFileAtomic(JoinPath(dir, "cameras.txt"), cams.str());

  std::ostringstream ims;
  ims << std::setprecision(17);
  ims << "# Image list with two lines of data per image:\n"
      << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      << "# Number of images: " << images.size() << "\n";
  for (const auto& [id, im] : images) {
    const auto& q = im.cam_from_world_rotation;
    const auto& t = im.cam_from_world_translation;
    ims << id << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " " << t.y() << " "
        << t.z() << " " << im.camera_id << " " << im.name << "\n";
    for (size_t i = 0; i < im.points2d.size(); ++i) {
      const auto& p = im.points2d[i];
      ims << (i ? " " : "") << p.xy.x() << " " << p.xy.y() << " "
          << (p.point3d_id == Point2D::kInvalidPoint3D ? -1LL : static_cast<long long>(p.point3d_id));
    }
    ims << "\n";
  }
  WriteFileAtomic(JoinPath(dir, "images.txt"), ims.str());

  std::ostringstream pts;
  pts << std::setprecision(17);
  pts << "# 3D point list with one line of data per point:\n"
      << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
      << "# Number of points: " << points3d.size() << "\n";
  for (const auto& [id, p] : points3d) {
    pts << id << " " << p.xyz.x() << " " << p.xyz.y() << " " << p.xyz.z() << " " << int(p.rgb[0]) << " "
        << int(p.rgb[1]) << " " << int(p.rgb[2]) << " " << p.error;
    for (const auto& [image_id, idx] : p.track) pts << " " << image_id << " " << idx;
    pts << "\n";
  }
  WriteFileAtomic(JoinPath(dir, "points3D.txt"), pts.str());
}

void Reconstruction::WriteBinary(const std::string& dir) const {
  std::string out;
  WritePod<uint64_t>(&out, cameras.size());
  for (const auto& [id, c] : cameras) {
    WritePod<uint32_t>(&out, id);
    WritePod<int32_t>(&out, Camera::ModelId(c.model));
    WritePod<uint64_t>(&out, static_cast<uint64_t>(c.width));
    WritePod<uint64_t>(&out, static_cast<uint64_t>(c.height));
    for (double p : c.params) WritePod<double>(&out, p);
  }
  WriteFileAtomic(JoinPath(dir, "cameras.bin"), out);

  out.clear();
  WritePod<uint64_t>(&out, images.size());
  for (const auto& [id, im] : images) {
    WritePod<uint32_t>(&out, id);
    const auto& q = im.cam_from_world_rotation;
    for (double v : {q.w(), q.x(), q.y(), q.z()}) WritePod<double>(&out, v);
    for (int k = 0; k < 3; ++k) WritePod<double>(&out, im.cam_from_world_translation[k]);
    WritePod<uint32_t>(&out, im.camera_id);
    out.append(im.name);
    out.push_back('\0');
    WritePod<uint64_t>(&out, im.points2d.size());
    for (const auto& p : im.points2d) {
      WritePod<double>(&out, p.xy.x());
      WritePod<double>(&out, p.xy.y());
      WritePod<uint64_t>(&out, p.point3d_id);
    }
  }
  WriteFileAtomic(JoinPath(dir, "images.bin"), out);

  out.clear();
  WritePod<uint64_t>(&out, points3d.size());
  for (const auto& [id, p] : points3d) {
    WritePod<uint64_t>(&out, id);
    for (int k = 0; k < 3; ++k) WritePod<double>(&out, p.xyz[k]);
    for (int k = 0; k < 3; ++k) WritePod<uint8_t>(&out, p.rgb[k]);
    WritePod<double>(&out, p.error);
    WritePod<uint64_t>(&out, p.track.size());
    for (const auto& [image_id, idx] : p.track) {
      WritePod<uint32_t>(&out, image_id);
      WritePod<uint32_t>(&out, idx);
    }
  }
  WriteFileAtomic(JoinPath(dir, "points3D.bin"), out);
}

const ImageRecord* Reconstruction::FindImage(const std::string& name) const {
  for (const auto& [id, im] : images)
    if (im.name == name) return &im;
  return nullptr;
}

bool Reconstruction::Project(const ImageRecord& image, const Eigen::Vector3d& point_world, Eigen::Vector2d* pixel,
                             double* depth) const {
  const Eigen::Vector3d p = image.CamFromWorld(point_world);
  if (depth != nullptr) *depth = p.z();
  if (p.z() <= 1e-12) return false;
  *pixel = cameras.at(image.camera_id).ImageFromCamera(p);
  return true;
}

void Reconstruction::Transform(const Sim3& t) {
  for (auto& [id, p] : points3d) p.xyz = t.Apply(p.xyz);
  for (auto& [id, im] : images) {
    const Eigen::Vector3d center = t.Apply(im.ProjectionCenter());
    const Eigen::Matrix3d r = im.CamFromWorldRotation() * t.rotation.transpose();
    im.SetPose(r, center);
  }
}

double Reconstruction::MeanReprojectionError() const {
  double sum = 0;
  long n = 0;
  for (const auto& [id, im] : images) {
    for (const auto& p : im.points2d) {
      if (p.point3d_id == Point2D::kInvalidPoint3D) continue;
      auto it = points3d.find(p.point3d_id);
      if (it == points3d.end()) continue;
      Eigen::Vector2d proj;
      if (!Project(im, it->second.xyz, &proj)) continue;
      sum += (proj - p.xy).norm();
      ++n;
    }
  }
  return n ? sum / n : 0.0;
}

}  // namespace relight
