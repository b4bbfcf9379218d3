// Typed, self-describing stage options.
//
// Every stage has one `XxxOptions` struct whose member initializers are the
// only defaults. The struct describes its fields once, in `Declare()`:
//
//   struct SynthesizeOptions {
//     int num_photos = 16;         // Photos to render.
//     std::string mesh;            // Mesh file (OBJ/PLY/OFF); empty: built-in shape.
//     void Declare(OptionTable* t) {
//       t->Add("num_photos", &num_photos, "Photos to render.").Min(1);
//       t->Add("mesh", &mesh, "Mesh file (OBJ/PLY/OFF).").InputFile();
//     }
//     void Check() const {}        // cross-field constraints, throws UserError
//   };
//
// From that one description the project derives: YAML parsing with file:line
// errors, `--set key=value` overrides, `--help` text, the config reference in
// docs, the canonical serialization that enters the cache key, and the fully
// resolved config written beside each stage's outputs.
//
// A stage shows users a handful of public options; `.Advanced()` moves tuning
// most runs leave alone to a second table, `.Experimental()` moves measurement
// switches out of both. `.OnlyWhen("mode", {"a"})` marks an option the other
// modes ignore: setting it then is an error (as pbrt treats unused parameters).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "core/fs.h"

namespace YAML {
class Node;
}

namespace relight {

// What a string option holds; input paths enter cache keys by content.
enum class PathRole {
  kNone,       // a plain string
  kInputFile,  // an existing file (or a list of them); content digests enter the cache key
  kInputDir,   // an existing folder; the digest of all its files enters the key
  kInputAny,   // an existing file or folder
  kOutput,     // a path the stage writes; never part of the key
};

// One option: a name, a typed pointer into the options struct, a doc line and constraints.
class OptionField {
 public:
  using Target = std::variant<bool*, int*, double*, std::string*, std::vector<double>*, std::vector<int>*,
                              std::vector<std::string>*>;

  OptionField(std::string name, Target target, std::string doc);

  // Constraints and roles (chainable).
  OptionField& Min(double v);
  OptionField& Max(double v);
  OptionField& Range(double lo, double hi) { return Min(lo).Max(hi); }
  OptionField& Choices(std::vector<std::string> allowed);
  OptionField& InputFile();
  OptionField& InputDir();
  OptionField& InputAny();
  OptionField& OutputPath();
  // The option does not change results (thread counts, log levels): kept out of the cache key.
  OptionField& NotInKey();
  // A list option must have exactly `n` entries.
  OptionField& Size(int n);
  // Tuning most runs leave alone: listed in the reference's advanced table, after the stage's public options.
  OptionField& Advanced();
  // A measurement switch (ground truth fed in, a superseded route kept for comparison): listed only in the
  // reference's closing table, and a stage run that sets it away from its default logs a warning.
  OptionField& Experimental();
  // The option matters only while option `controller` of the same section holds one of `values` (canonical
  // text: "true" for a bool). The reference says so, and OptionTable::Validate rejects a value other than the
  // default while the condition is false (an ignored option is a mistake). Repeatable: all must hold.
  OptionField& OnlyWhen(std::string controller, std::vector<std::string> values);
  // An input folder: the files the stage reads from it (called when the key is
  // computed, so it may depend on other options of the same struct). Only
  // these files' names and contents enter the cache key. Default: every file.
  OptionField& Reads(std::function<FileSelection()> selection);

  const std::string& name() const { return name_; }
  const std::string& doc() const { return doc_; }
  PathRole path_role() const { return path_role_; }
  bool in_key() const { return in_key_; }
  bool is_input_path() const;
  // The files of an input folder the stage reads (Reads(); default: all).
  FileSelection selection() const { return selection_ ? selection_() : FileSelection{}; }
  const std::vector<std::string>& choices() const { return choices_; }
  enum class Tier { kPublic, kAdvanced, kExperimental };
  Tier tier() const { return tier_; }
  // One OnlyWhen() condition: the controlling option and the values under which this one matters.
  struct Condition {
    std::string controller;
    std::vector<std::string> values;
  };
  const std::vector<Condition>& conditions() const { return conditions_; }
  // The conditions as text: "only when lighting_basis: sh"; "" when none.
  std::string ConditionText() const;
  // True when the current value equals the default.
  bool is_default() const { return ValueText() == default_text_; }
  // "file:line" (or "--set key") where the value was last set; "" while it is the declared default.
  const std::string& set_where() const { return set_where_; }
  // "int", "float", "bool", "string", "path", "list of float", ...
  std::string TypeName() const;
  // Human readable constraints: "≥ 1", "one of: a, b", "" when none.
  std::string ConstraintText() const;
  // The value at declaration time (the default), canonical text.
  const std::string& default_text() const { return default_text_; }
  // The current value, canonical text (floats with %.17g, lists as [a, b]).
  std::string ValueText() const;
  // String value of a path/string option (empty for other types).
  std::string StringValue() const;
  // The paths of a path option (single or list); empty entries omitted.
  std::vector<std::string> PathValues() const;
  // Makes relative paths of a path option absolute against `base_dir`.
  void ResolvePaths(const std::string& base_dir);
  const Target& target() const { return target_; }
  void SetStringValue(const std::string& value);

  // Set from a YAML scalar or sequence; `where` is "file:line" for messages.
  void SetFromYaml(const YAML::Node& node, const std::string& where);
  // Set from command-line text ("16", "0.5", "true", "a,b,c").
  void SetFromText(const std::string& text, const std::string& where);
  // Emit the current value into a YAML node.
  void ToYaml(YAML::Node* node) const;

  // Throws UserError naming `where` when the value violates a constraint.
  void Validate(const std::string& where) const;

 private:
  std::string name_;
  Target target_;
  std::string doc_;
  std::optional<double> min_;
  std::optional<double> max_;
  std::optional<int> size_;
  std::vector<std::string> choices_;
  PathRole path_role_ = PathRole::kNone;
  bool in_key_ = true;
  Tier tier_ = Tier::kPublic;
  std::vector<Condition> conditions_;
  std::string default_text_;
  std::string set_where_;
  std::function<FileSelection()> selection_;
};

// All options of one section (a stage, or `pipeline`).
class OptionTable {
 public:
  explicit OptionTable(std::string section) : section_(std::move(section)) {}

  template <typename T>
  OptionField& Add(const std::string& name, T* target, const std::string& doc) {
    fields_.emplace_back(name, OptionField::Target(target), doc);
    return fields_.back();
  }

  // A key that no longer exists: a config that sets it fails with `what_to_do` (which names the key that
  // replaced it, or says to delete it) instead of the generic unknown-option message.
  void Retired(const std::string& name, const std::string& what_to_do) { retired_[name] = what_to_do; }

  const std::string& section() const { return section_; }
  std::vector<OptionField>& fields() { return fields_; }
  const std::vector<OptionField>& fields() const { return fields_; }
  OptionField* Find(const std::string& name);
  const OptionField* Find(const std::string& name) const;

  // Applies a YAML mapping of this section. Unknown keys and bad values throw
  // UserError naming `file`, the line and the allowed keys/values. Relative
  // paths are resolved against `base_dir` (the config file's folder).
  void ApplyYaml(const YAML::Node& mapping, const std::string& file, const std::string& base_dir);
  // Applies one `name: value` entry; `key_where` is "file:line" of the key, the
  // value node keeps its own line mark.
  void ApplyEntry(const std::string& name, const std::string& key_where, const YAML::Node& value,
                  const std::string& file, const std::string& base_dir);
  // Applies one `name=value` override (from --set); relative paths resolve against the CWD.
  void ApplyText(const std::string& name, const std::string& value, const std::string& where);
  // Validates every field's constraints, then the OnlyWhen() conditions: an option set away from its default
  // while its controlling option makes the stage ignore it throws UserError naming both and what to do.
  void Validate(const std::string& where) const;

  // Content digest of an input path: a file's bytes, or the files a folder
  // option reads from it (DigestCache::Digest).
  using DigestFn = std::function<std::string(const std::string& path, const FileSelection& selection)>;
  // Canonical text of the result-affecting options: one sorted line per
  // field, `section.name=value`. Input paths are replaced by `digest(path)`.
  // Throws UserError naming the option when an input file is a folder or an
  // input folder is a file.
  std::string CanonicalText(const DigestFn& digest) const;
  // The resolved values as a YAML mapping node (all fields, including NotInKey ones).
  YAML::Node ToYaml() const;
  // Markdown tables (key, type, default, constraints, doc): the public options, then, under a heading
  // "#### <section> — advanced", the advanced ones. Experimental options are left out.
  std::string MarkdownReference() const;
  // Table rows (no header) of the experimental options, for the reference's closing table; "" when none.
  std::string MarkdownExperimentalRows() const;
  // Plain text for --help: public options, then advanced ones, then measurement switches.
  std::string HelpText() const;
  // Names of the experimental options whose value is not the default (a stage warns about them).
  std::vector<std::string> ExperimentalInUse() const;

 private:
  std::map<std::string, std::string> retired_;  // name -> what to do
  std::string section_;
  // A deque would keep references stable; fields are only added in Declare(), before use.
  std::vector<OptionField> fields_;
};

// Builds the option table of an options struct (calls `Declare`).
template <typename Options>
OptionTable MakeOptionTable(const std::string& section, Options* options) {
  OptionTable table(section);
  options->Declare(&table);
  return table;
}

// Formats a double canonically (round-trip exact, locale independent).
std::string CanonicalDouble(double v);

}  // namespace relight
