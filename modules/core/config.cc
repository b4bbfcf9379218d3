#include "core/config.h"

#include <algorithm>
#include <filesystem>
#include <map>

#include "core/error.h"

namespace relight {
namespace fs = std::filesystem;

namespace {
std::string Where(const YAML::Node& node, const std::string& file) {
  const YAML::Mark mark = node.Mark();
  return mark.line < 0 ? file : file + ":" + std::to_string(mark.line + 1);
}
}  // namespace

ConfigDocument ConfigDocument::Load(const std::string& path) {
  ConfigDocument doc;
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec).lexically_normal();
  if (!fs::is_regular_file(abs, ec)) {
    RELIGHT_USER_ERROR() << "config file '" << path << "' does not exist; pass the path of a YAML config "
                         << "(see configs/README.md)";
  }
  doc.path_ = abs.string();
  doc.LoadFile(doc.path_, 0);
  return doc;
}

void ConfigDocument::LoadFile(const std::string& file, int depth) {
  if (depth > 8) RELIGHT_USER_ERROR() << file << ": 'base:' chain is deeper than 8 files (a cycle?)";
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::ParserException& e) {
    RELIGHT_USER_ERROR() << file << ":" << e.mark.line + 1 << ": YAML syntax error: " << e.msg;
  } catch (const YAML::BadFile&) {
    RELIGHT_USER_ERROR() << "cannot read config file '" << file << "'";
  }
  if (root.IsNull()) return;  // an empty file is a valid, all-defaults config
  if (!root.IsMap()) {
    RELIGHT_USER_ERROR() << Where(root, file) << ": a config must be a mapping of sections "
                         << "(e.g. 'synthesize:' with options below it)";
  }
  const std::string base_dir = fs::path(file).parent_path().string();
  if (const YAML::Node base = root["base"]) {
    if (!base.IsScalar()) RELIGHT_USER_ERROR() << Where(base, file) << ": 'base' must be a file path";
    fs::path base_path = fs::path(base.Scalar());
    if (base_path.is_relative()) base_path = fs::path(base_dir) / base_path;
    base_path = base_path.lexically_normal();
    std::error_code ec;  // a name too long for the file system is an error code, not an exception
    if (!fs::is_regular_file(base_path, ec)) {
      RELIGHT_USER_ERROR() << Where(base, file) << ": base config '" << base.Scalar().substr(0, 200)
                           << (base.Scalar().size() > 200 ? "..." : "") << "' "
                           << (ec && ec != std::errc::no_such_file_or_directory ? "cannot be read (" + ec.message() + ")"
                                                                                : std::string("does not exist"));
    }
    LoadFile(base_path.string(), depth + 1);
  }
  // YAML parsers keep the last of two equal keys; in a config that silently
  // drops half of a section, so a repeated section or option is an error.
  std::map<std::string, std::string> sections_here, options_here;  // name -> where first seen in this file
  auto first_time = [](std::map<std::string, std::string>* seen, const std::string& name, const std::string& where) {
    auto [it, inserted] = seen->emplace(name, where);
    return inserted ? std::string() : it->second;
  };
  auto add_entry = [&](const std::string& section, const std::string& field, const std::string& where,
                       const YAML::Node& value) {
    const std::string earlier = first_time(&options_here, section + "." + field, where);
    if (!earlier.empty()) {
      RELIGHT_USER_ERROR() << where << ": option '" << section << "." << field << "' is set twice in this file (first at "
                           << earlier << "); keep one of them";
    }
    sections_[section].push_back(ConfigEntry{field, where, value, file, base_dir});
  };
  for (const auto& kv : root) {
    const std::string key = kv.first.Scalar();
    if (key == "base") continue;
    const std::string where = Where(kv.first, file);
    const size_t dot = key.find('.');
    if (dot != std::string::npos) {  // flat form `section.field: value`
      const std::string section = key.substr(0, dot);
      section_where_.emplace(section, where);
      add_entry(section, key.substr(dot + 1), where, kv.second);
      continue;
    }
    const std::string earlier = first_time(&sections_here, key, where);
    if (!earlier.empty()) {
      RELIGHT_USER_ERROR() << where << ": section '" << key << "' appears twice in this file (first at " << earlier
                           << "); merge the two into one";
    }
    section_where_.emplace(key, where);
    sections_[key];  // an empty section still counts as present
    if (kv.second.IsNull()) continue;
    if (!kv.second.IsMap()) {
      // Reported by CheckSections (after unknown section names) or Apply.
      malformed_.emplace(key, where);
      continue;
    }
    for (const auto& field : kv.second) add_entry(key, field.first.Scalar(), Where(field.first, file), field.second);
  }
}

void ConfigDocument::CheckMapping(const std::string& section) const {
  auto it = malformed_.find(section);
  if (it == malformed_.end()) return;
  RELIGHT_USER_ERROR() << it->second << ": section '" << section << "' must be a mapping of option: value (or write '"
                       << section << ".OPTION: value')";
}

std::string ConfigDocument::stem() const { return path_.empty() ? "default" : fs::path(path_).stem().string(); }

std::vector<std::string> ConfigDocument::SectionNames() const {
  std::vector<std::string> names;
  for (const auto& [name, entries] : sections_) names.push_back(name);
  return names;
}

void ConfigDocument::CheckSections(const std::vector<std::string>& known) const {
  std::string allowed;
  for (size_t i = 0; i < known.size(); ++i) allowed += (i ? ", " : "") + known[i];
  for (const auto& [name, entries] : sections_) {
    if (std::find(known.begin(), known.end(), name) != known.end()) continue;
    RELIGHT_USER_ERROR() << section_where_.at(name) << ": unknown section '" << name
                         << "'; allowed sections: " << allowed;
  }
  for (const auto& [name, where] : malformed_) CheckMapping(name);
  for (const auto& [key, value] : overrides_) {
    const std::string section = key.substr(0, key.find('.'));
    if (std::find(known.begin(), known.end(), section) == known.end()) {
      RELIGHT_USER_ERROR() << "--set " << key << ": unknown section '" << section << "'; allowed sections: "
                           << allowed;
    }
  }
}

void ConfigDocument::Apply(OptionTable* table) const {
  CheckMapping(table->section());
  auto it = sections_.find(table->section());
  if (it != sections_.end()) {
    for (const ConfigEntry& e : it->second) table->ApplyEntry(e.field, e.where, e.value, e.file, e.base_dir);
  }
  for (const auto& [key, value] : overrides_) {
    const size_t dot = key.find('.');
    if (key.substr(0, dot) != table->section()) continue;
    table->ApplyText(key.substr(dot + 1), value, "--set " + key);
  }
  table->Validate(path_.empty() ? "options" : path_);
}

void ConfigDocument::AddOverride(const std::string& assignment) {
  const size_t eq = assignment.find('=');
  const size_t dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq) {
    RELIGHT_USER_ERROR() << "--set '" << assignment << "': expected SECTION.OPTION=VALUE, e.g. "
                         << "--set synthesize.num_photos=12";
  }
  overrides_.emplace_back(assignment.substr(0, eq), assignment.substr(eq + 1));
}

}  // namespace relight
