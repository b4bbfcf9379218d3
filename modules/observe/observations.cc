#include "observe/observations.h"

#include <cstring>
#include <fstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"

namespace relight {
namespace {
template <typename T>
void Put(std::string* out, const T& v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
}  // namespace

void WriteObservations(const std::string& path, const ObservationSet& set) {
  std::string out;
  out.reserve(32 + set.records.size() * sizeof(Observation));
  out.append(kObservationsMagic, 8);
  Put(&out, kObservationsVersion);
  Put(&out, set.num_photos);
  Put(&out, set.num_vertices);
  Put(&out, static_cast<uint64_t>(set.records.size()));
  for (const Observation& o : set.records) {
    Put(&out, o.photo);
    Put(&out, o.vertex);
    out.append(reinterpret_cast<const char*>(o.rgb), 12);
    Put(&out, o.confidence);
    out.append(reinterpret_cast<const char*>(o.view_local), 12);
    Put(&out, o.flags);
    Put(&out, o.kernel_scale);
  }
  WriteFileAtomic(path, out);
}

ObservationSet ReadObservations(const std::string& path) {
  const std::string data = ReadFileToString(path);
  auto damaged = [&](const std::string& why) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not a valid observation file (" << why
                         << "); rerun the observe stage (pipeline run CONFIG --from observe)";
  };
  if (data.size() < 28 || std::memcmp(data.data(), kObservationsMagic, 8) != 0) damaged("bad magic");
  size_t pos = 8;
  auto get = [&](void* dst, size_t n) {
    if (pos + n > data.size()) damaged("truncated");
    std::memcpy(dst, data.data() + pos, n);
    pos += n;
  };
  uint32_t version;
  get(&version, 4);
  if (version < 1 || version > kObservationsVersion) {
    damaged("version " + std::to_string(version) + ", this build reads 1 to " + std::to_string(kObservationsVersion));
  }
  ObservationSet set;
  uint64_t count;
  get(&set.num_photos, 4);
  get(&set.num_vertices, 4);
  get(&count, 8);
  const size_t record_bytes = version == 1 ? 36 : version <= 3 ? 40 : 44;  // 1 had no flags, 4 added kernel_scale
  const size_t body = data.size() - pos;  // compared by division: count * record_bytes may overflow
  if (body % record_bytes != 0 || count != body / record_bytes) damaged("size does not match the record count");
  set.records.resize(count);
  for (Observation& o : set.records) {
    get(&o.photo, 4);
    get(&o.vertex, 4);
    get(o.rgb, 12);
    get(&o.confidence, 4);
    get(o.view_local, 12);
    if (version >= 2) get(&o.flags, 4);
    if (version >= 4) {
      get(&o.kernel_scale, 4);
      if (!(o.kernel_scale > 0 && o.kernel_scale < 1e6f)) damaged("kernel_scale not a positive number");
    }
    if (o.flags & ~(kObservationLowerBound | kObservationBoundChannels)) damaged("unknown flags");
    if (version < 3 && (o.flags & kObservationBoundChannels)) damaged("per-channel flags in a version 2 file");
    if ((o.flags & kObservationBoundChannels) && !(o.flags & kObservationLowerBound)) {
      damaged("bound channels without the lower-bound flag");
    }
    if (o.photo >= set.num_photos || o.vertex >= set.num_vertices) damaged("index out of range");
  }
  return set;
}

void WriteObservedPhotos(const std::string& path, const std::vector<ObservedPhoto>& photos, double footprint_scale) {
  Json j = Json::array();
  for (const auto& p : photos) {
    const auto& q = p.pose.cam_from_world_rotation;
    const auto& t = p.pose.cam_from_world_translation;
    j.push_back({{"index", p.index},
                 {"name", p.name},
                 {"linear", p.linear},
                 {"camera",
                  {{"model", p.camera.model}, {"width", p.camera.width}, {"height", p.camera.height},
                   {"params", p.camera.params}}},
                 {"cam_from_world_qvec", {q.w(), q.x(), q.y(), q.z()}},
                 {"cam_from_world_tvec", {t.x(), t.y(), t.z()}},
                 {"observed_vertices", p.observed_vertices},
                 {"mean_confidence", p.mean_confidence}});
  }
  WriteJsonAtomic(path, Json{{"format", "relight-observed-photos"},
                              {"version", 1},
                              {"footprint_scale", footprint_scale},
                              {"photos", j}});
}

double ReadObservedFootprintScale(const std::string& path) {
  const Json j = ReadJsonFile(path);
  const auto it = j.find("footprint_scale");
  if (it == j.end()) return 1.0;
  if (!it->is_number() || !(it->get<double>() > 0)) {
    RELIGHT_USER_ERROR() << "'" << path << "' has a footprint_scale that is not a positive number; rerun the observe stage";
  }
  return it->get<double>();
}

std::vector<ObservedPhoto> ReadObservedPhotos(const std::string& path) {
  const Json j = ReadJsonFile(path);
  std::vector<ObservedPhoto> photos;
  try {
    for (const auto& p : j.at("photos")) {
      ObservedPhoto o;
      o.index = p.at("index");
      o.name = p.at("name");
      o.linear = p.at("linear");
      o.camera.model = p.at("camera").at("model");
      o.camera.width = p.at("camera").at("width");
      o.camera.height = p.at("camera").at("height");
      o.camera.params = p.at("camera").at("params").get<std::vector<double>>();
      const auto q = p.at("cam_from_world_qvec").get<std::vector<double>>();
      const auto t = p.at("cam_from_world_tvec").get<std::vector<double>>();
      o.pose.name = o.name;
      o.pose.cam_from_world_rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
      o.pose.cam_from_world_translation = Eigen::Vector3d(t[0], t[1], t[2]);
      o.observed_vertices = p.value("observed_vertices", 0u);
      o.mean_confidence = p.value("mean_confidence", 0.0);
      photos.push_back(o);
    }
  } catch (const Json::exception& e) {
    RELIGHT_USER_ERROR() << "'" << path << "' is malformed (" << e.what() << "); rerun the observe stage";
  }
  return photos;
}

}  // namespace relight
