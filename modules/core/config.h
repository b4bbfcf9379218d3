// A YAML config file: sections of `stage.field` options.
//
// Both spellings are accepted and may be mixed:
//   synthesize:               synthesize.num_photos: 16
//     num_photos: 16
// A top-level `base: other.yaml` loads that file first (paths in each file are
// relative to the file that names them); later entries override earlier ones.
// Within one file a section or an option may appear only once.
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <string>
#include <vector>

#include "core/options.h"

namespace relight {

// One `field: value` entry of a section, with where it came from.
struct ConfigEntry {
  std::string field;     // option name within the section
  std::string where;     // "file:line" of the key
  YAML::Node value;      // keeps its own line mark
  std::string file;      // absolute path of the file holding the entry
  std::string base_dir;  // folder relative paths resolve against
};

class ConfigDocument {
 public:
  // Loads and parses `path` (and its `base:` chain). Throws UserError with file:line on syntax errors.
  static ConfigDocument Load(const std::string& path);
  // An empty document (all defaults).
  static ConfigDocument Empty() { return ConfigDocument(); }

  // Absolute path of the top-level config file ("" for Empty()).
  const std::string& path() const { return path_; }
  // Config file name without folder and extension ("liberty" for configs/liberty.yaml).
  std::string stem() const;
  bool HasSection(const std::string& section) const { return sections_.count(section) > 0; }
  std::vector<std::string> SectionNames() const;
  // Throws UserError naming the file and line of the first section not in `known`.
  void CheckSections(const std::vector<std::string>& known) const;
  // Applies the entries of `table->section()` (later entries win), then --set overrides, and validates.
  void Apply(OptionTable* table) const;
  // Adds an override `section.field=value` (from the command line).
  void AddOverride(const std::string& assignment);

 private:
  void LoadFile(const std::string& path, int depth);
  // Throws UserError naming the file and line when `section` is not a mapping.
  void CheckMapping(const std::string& section) const;

  std::string path_;
  std::map<std::string, std::vector<ConfigEntry>> sections_;
  std::map<std::string, std::string> section_where_;  // first mention of each section, for errors
  std::map<std::string, std::string> malformed_;      // sections whose value is not a mapping -> where
  std::vector<std::pair<std::string, std::string>> overrides_;
};

}  // namespace relight
