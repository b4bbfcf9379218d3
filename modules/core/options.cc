#include "core/options.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/text.h"

namespace relight {
namespace {

namespace fs = std::filesystem;

template <typename... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <typename... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

std::string JoinStrings(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) {
    if (i) out += sep;
    out += items[i];
  }
  return out;
}

std::vector<std::string> SplitList(std::string text) {
  text = TrimWhitespace(text);
  if (!text.empty() && text.front() == '[' && text.back() == ']') text = text.substr(1, text.size() - 2);
  std::vector<std::string> out;
  if (TrimWhitespace(text).empty()) return out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    item = TrimWhitespace(item);
    // YAML flow-list items may be quoted ("phong:500" or 'phong:500'), as in a config file.
    if (item.size() >= 2 && (item.front() == '"' || item.front() == '\'') && item.back() == item.front()) {
      item = item.substr(1, item.size() - 2);
    }
    out.push_back(item);
  }
  return out;
}

bool ParseBool(const std::string& text, bool* value) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), ::tolower);
  if (t == "true" || t == "yes" || t == "on" || t == "1") {
    *value = true;
    return true;
  }
  if (t == "false" || t == "no" || t == "off" || t == "0") {
    *value = false;
    return true;
  }
  return false;
}

bool ParseInt(const std::string& text, int* value) {
  std::string t = TrimWhitespace(text);
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  long v = std::strtol(t.c_str(), &end, 10);
  if (errno != 0 || *end != '\0' || v < INT32_MIN || v > INT32_MAX) return false;
  *value = static_cast<int>(v);
  return true;
}

bool ParseDouble(const std::string& text, double* value) {
  std::string t = TrimWhitespace(text);
  if (t.empty()) return false;
  std::istringstream ss(t);
  ss.imbue(std::locale::classic());
  double v;
  ss >> v;
  if (ss.fail() || !ss.eof() || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

std::string ResolvePath(const std::string& path, const std::string& base_dir) {
  if (path.empty() || base_dir.empty()) return path;
  fs::path p(path);
  if (p.is_absolute()) return p.lexically_normal().string();
  return (fs::path(base_dir) / p).lexically_normal().string();
}

std::string LineOf(const YAML::Node& node, const std::string& file) {
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return file;
  return file + ":" + std::to_string(mark.line + 1);
}

}  // namespace

std::string CanonicalDouble(double v) {
  if (v == 0.0) return "0";  // fold -0
  // Shortest text that round-trips exactly, locale independent (C++17 to_chars).
  char buf[64];
  const auto result = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, result.ptr);
}

OptionField::OptionField(std::string name, Target target, std::string doc)
    : name_(std::move(name)), target_(target), doc_(std::move(doc)) {
  default_text_ = ValueText();
}

OptionField& OptionField::Min(double v) {
  min_ = v;
  return *this;
}
OptionField& OptionField::Max(double v) {
  max_ = v;
  return *this;
}
OptionField& OptionField::Size(int n) {
  size_ = n;
  return *this;
}
OptionField& OptionField::Choices(std::vector<std::string> allowed) {
  choices_ = std::move(allowed);
  return *this;
}
OptionField& OptionField::InputFile() {
  path_role_ = PathRole::kInputFile;
  return *this;
}
OptionField& OptionField::InputDir() {
  path_role_ = PathRole::kInputDir;
  return *this;
}
OptionField& OptionField::InputAny() {
  path_role_ = PathRole::kInputAny;
  return *this;
}
OptionField& OptionField::OutputPath() {
  path_role_ = PathRole::kOutput;
  return *this;
}
OptionField& OptionField::Reads(std::function<FileSelection()> selection) {
  selection_ = std::move(selection);
  return *this;
}
OptionField& OptionField::NotInKey() {
  in_key_ = false;
  return *this;
}
OptionField& OptionField::Advanced() {
  tier_ = Tier::kAdvanced;
  return *this;
}
OptionField& OptionField::Experimental() {
  tier_ = Tier::kExperimental;
  return *this;
}
OptionField& OptionField::OnlyWhen(std::string controller, std::vector<std::string> values) {
  conditions_.push_back({std::move(controller), std::move(values)});
  return *this;
}

std::string OptionField::ConditionText() const {
  std::vector<std::string> parts;
  for (const auto& c : conditions_) parts.push_back(c.controller + ": " + JoinStrings(c.values, " or "));
  return parts.empty() ? "" : "only when " + JoinStrings(parts, " and ");
}

bool OptionField::is_input_path() const {
  return path_role_ == PathRole::kInputFile || path_role_ == PathRole::kInputDir ||
         path_role_ == PathRole::kInputAny;
}

std::string OptionField::TypeName() const {
  return std::visit(Overloaded{[](bool*) { return std::string("bool"); },
                               [](int*) { return std::string("int"); },
                               [](double*) { return std::string("float"); },
                               [this](std::string*) {
                                 return std::string(path_role_ == PathRole::kNone ? "string" : "path");
                               },
                               [](std::vector<double>*) { return std::string("list of float"); },
                               [](std::vector<int>*) { return std::string("list of int"); },
                               [](std::vector<std::string>*) { return std::string("list of string"); }},
                    target_);
}

std::string OptionField::ConstraintText() const {
  std::vector<std::string> parts;
  if (min_ && max_) {
    parts.push_back("in [" + CanonicalDouble(*min_) + ", " + CanonicalDouble(*max_) + "]");
  } else if (min_) {
    parts.push_back(">= " + CanonicalDouble(*min_));
  } else if (max_) {
    parts.push_back("<= " + CanonicalDouble(*max_));
  }
  if (!choices_.empty()) parts.push_back("one of: " + JoinStrings(choices_, ", "));
  if (size_) parts.push_back(std::to_string(*size_) + " entries");
  switch (path_role_) {
    case PathRole::kInputFile: parts.push_back("existing file"); break;
    case PathRole::kInputDir: parts.push_back("existing folder"); break;
    case PathRole::kInputAny: parts.push_back("existing file or folder"); break;
    default: break;
  }
  return JoinStrings(parts, "; ");
}

std::string OptionField::ValueText() const {
  return std::visit(
      Overloaded{[](bool* v) { return std::string(*v ? "true" : "false"); },
                 [](int* v) { return std::to_string(*v); },
                 [](double* v) { return CanonicalDouble(*v); },
                 [](std::string* v) { return *v; },
                 [](std::vector<double>* v) {
                   std::vector<std::string> items;
                   for (double x : *v) items.push_back(CanonicalDouble(x));
                   return "[" + JoinStrings(items, ", ") + "]";
                 },
                 [](std::vector<int>* v) {
                   std::vector<std::string> items;
                   for (int x : *v) items.push_back(std::to_string(x));
                   return "[" + JoinStrings(items, ", ") + "]";
                 },
                 [](std::vector<std::string>* v) { return "[" + JoinStrings(*v, ", ") + "]"; }},
      target_);
}

void OptionField::ResolvePaths(const std::string& base_dir) {
  if (path_role_ == PathRole::kNone) return;
  if (auto* s = std::get_if<std::string*>(&target_)) **s = ResolvePath(**s, base_dir);
  if (auto* list = std::get_if<std::vector<std::string>*>(&target_)) {
    for (auto& item : **list) item = ResolvePath(item, base_dir);
  }
}

std::vector<std::string> OptionField::PathValues() const {
  if (auto* s = std::get_if<std::string*>(&target_)) return (*s)->empty() ? std::vector<std::string>{} : std::vector<std::string>{**s};
  if (auto* list = std::get_if<std::vector<std::string>*>(&target_)) return **list;
  return {};
}

std::string OptionField::StringValue() const {
  if (auto* s = std::get_if<std::string*>(&target_)) return **s;
  return "";
}

void OptionField::SetStringValue(const std::string& value) {
  if (auto* s = std::get_if<std::string*>(&target_)) **s = value;
}

void OptionField::SetFromText(const std::string& text, const std::string& where) {
  const std::string key = name_;
  auto fail = [&](const std::string& expected) {
    RELIGHT_USER_ERROR() << where << ": option '" << key << "' expects " << expected << ", got '" << text
                         << "'";
  };
  std::visit(Overloaded{[&](bool* v) {
                          if (!ParseBool(text, v)) fail("true or false");
                        },
                        [&](int* v) {
                          if (!ParseInt(text, v)) fail("an integer");
                        },
                        [&](double* v) {
                          if (!ParseDouble(text, v)) fail("a number");
                        },
                        [&](std::string* v) { *v = text; },
                        [&](std::vector<double>* v) {
                          v->clear();
                          for (const auto& item : SplitList(text)) {
                            double x;
                            if (!ParseDouble(item, &x)) fail("a list of numbers");
                            v->push_back(x);
                          }
                        },
                        [&](std::vector<int>* v) {
                          v->clear();
                          for (const auto& item : SplitList(text)) {
                            int x;
                            if (!ParseInt(item, &x)) fail("a list of integers");
                            v->push_back(x);
                          }
                        },
                        [&](std::vector<std::string>* v) { *v = SplitList(text); }},
             target_);
  set_where_ = where;
  Validate(where);
}

void OptionField::SetFromYaml(const YAML::Node& node, const std::string& where) {
  const bool is_list = std::holds_alternative<std::vector<double>*>(target_) ||
                       std::holds_alternative<std::vector<int>*>(target_) ||
                       std::holds_alternative<std::vector<std::string>*>(target_);
  if (node.IsSequence()) {
    if (!is_list) {
      RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' expects a single " << TypeName()
                           << ", got a list";
    }
    std::vector<std::string> items;
    for (const auto& item : node) {
      if (!item.IsScalar()) {
        RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' expects a " << TypeName();
      }
      items.push_back(item.Scalar());
    }
    if (std::holds_alternative<std::vector<std::string>*>(target_)) {
      *std::get<std::vector<std::string>*>(target_) = items;
      set_where_ = where;
      Validate(where);
    } else {
      SetFromText(JoinStrings(items, ","), where);
    }
    return;
  }
  if (node.IsNull()) {
    if (std::holds_alternative<std::string*>(target_)) {
      *std::get<std::string*>(target_) = "";
      set_where_ = where;
      return;
    }
    RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' has no value; expected a " << TypeName();
  }
  if (!node.IsScalar()) {
    RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' expects a " << TypeName()
                         << ", got a mapping";
  }
  SetFromText(node.Scalar(), where);
}

void OptionField::ToYaml(YAML::Node* node) const {
  std::visit(Overloaded{[&](bool* v) { (*node)[name_] = *v; }, [&](int* v) { (*node)[name_] = *v; },
                        [&](double* v) { (*node)[name_] = CanonicalDouble(*v); },
                        [&](std::string* v) { (*node)[name_] = *v; },
                        [&](std::vector<double>* v) {
                          YAML::Node seq(YAML::NodeType::Sequence);
                          for (double x : *v) seq.push_back(CanonicalDouble(x));
                          seq.SetStyle(YAML::EmitterStyle::Flow);
                          (*node)[name_] = seq;
                        },
                        [&](std::vector<int>* v) {
                          YAML::Node seq(YAML::NodeType::Sequence);
                          for (int x : *v) seq.push_back(x);
                          seq.SetStyle(YAML::EmitterStyle::Flow);
                          (*node)[name_] = seq;
                        },
                        [&](std::vector<std::string>* v) {
                          YAML::Node seq(YAML::NodeType::Sequence);
                          for (const auto& x : *v) seq.push_back(x);
                          seq.SetStyle(YAML::EmitterStyle::Flow);
                          (*node)[name_] = seq;
                        }},
             target_);
}

void OptionField::Validate(const std::string& where) const {
  auto check_number = [&](double x) {
    if ((min_ && x < *min_) || (max_ && x > *max_)) {
      RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' = " << CanonicalDouble(x)
                           << " is out of range; allowed: " << ConstraintText();
    }
  };
  auto check_choice = [&](const std::string& s) {
    if (!choices_.empty() && std::find(choices_.begin(), choices_.end(), s) == choices_.end()) {
      RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' = '" << s
                           << "' is not allowed; allowed values: " << JoinStrings(choices_, ", ");
    }
  };
  auto check_size = [&](size_t n) {
    if (size_ && static_cast<int>(n) != *size_) {
      RELIGHT_USER_ERROR() << where << ": option '" << name_ << "' needs exactly " << *size_
                           << " entries, got " << n;
    }
  };
  std::visit(Overloaded{[&](bool*) {}, [&](int* v) { check_number(*v); },
                        [&](double* v) { check_number(*v); }, [&](std::string* v) { check_choice(*v); },
                        [&](std::vector<double>* v) {
                          check_size(v->size());
                          for (double x : *v) check_number(x);
                        },
                        [&](std::vector<int>* v) {
                          check_size(v->size());
                          for (int x : *v) check_number(x);
                        },
                        [&](std::vector<std::string>* v) {
                          check_size(v->size());
                          for (const auto& x : *v) check_choice(x);
                        }},
             target_);
}

OptionField* OptionTable::Find(const std::string& name) {
  for (auto& f : fields_)
    if (f.name() == name) return &f;
  return nullptr;
}

const OptionField* OptionTable::Find(const std::string& name) const {
  for (const auto& f : fields_)
    if (f.name() == name) return &f;
  return nullptr;
}

void OptionTable::ApplyYaml(const YAML::Node& mapping, const std::string& file, const std::string& base_dir) {
  if (mapping.IsNull()) return;
  if (!mapping.IsMap()) {
    RELIGHT_USER_ERROR() << LineOf(mapping, file) << ": section '" << section_
                         << "' must be a mapping of option: value";
  }
  for (const auto& kv : mapping) ApplyEntry(kv.first.Scalar(), LineOf(kv.first, file), kv.second, file, base_dir);
}

void OptionTable::ApplyEntry(const std::string& name, const std::string& where, const YAML::Node& value,
                             const std::string& file, const std::string& base_dir) {
  OptionField* field = Find(name);
  if (field == nullptr && retired_.count(name)) {
    RELIGHT_USER_ERROR() << where << ": option '" << section_ << "." << name << "' was removed: " << retired_.at(name);
  }
  if (field == nullptr) {
    std::vector<std::string> names;
    for (const auto& f : fields_) names.push_back(f.name());
    RELIGHT_USER_ERROR() << where << ": unknown option '" << section_ << "." << name
                         << "'; allowed options of '" << section_ << "': " << JoinStrings(names, ", ");
  }
  field->SetFromYaml(value, LineOf(value, file));
  field->ResolvePaths(base_dir);
}

void OptionTable::ApplyText(const std::string& name, const std::string& value, const std::string& where) {
  OptionField* field = Find(name);
  if (field == nullptr && retired_.count(name)) {
    RELIGHT_USER_ERROR() << where << ": option '" << section_ << "." << name << "' was removed: " << retired_.at(name);
  }
  if (field == nullptr) {
    std::vector<std::string> names;
    for (const auto& f : fields_) names.push_back(f.name());
    RELIGHT_USER_ERROR() << where << ": unknown option '" << section_ << "." << name
                         << "'; allowed options of '" << section_ << "': " << JoinStrings(names, ", ");
  }
  field->SetFromText(value, where);
  field->ResolvePaths(fs::current_path().string());
}

void OptionTable::Validate(const std::string& where) const {
  for (const auto& f : fields_) f.Validate(where);
  for (const auto& f : fields_) {
    for (const auto& c : f.conditions()) {
      const OptionField* controller = Find(c.controller);
      RELIGHT_CHECK(controller != nullptr)
          << section_ << "." << f.name() << ": OnlyWhen names no option '" << c.controller << "'";
      const std::string state = controller->ValueText();
      if (f.is_default() || std::find(c.values.begin(), c.values.end(), state) != c.values.end()) continue;
      RELIGHT_USER_ERROR() << (f.set_where().empty() ? where : f.set_where()) << ": option '" << section_ << "."
                           << f.name() << "' = " << f.ValueText() << " has no effect while " << section_ << "."
                           << c.controller << " is '" << state << "' (it applies only when " << c.controller << " is "
                           << JoinStrings(c.values, " or ")
                           << "): remove the key (or, when a base config sets it, set it to its "
                           << "default " << (f.default_text().empty() ? "\"\"" : f.default_text()) << "), or set "
                           << section_ << "." << c.controller << ": " << c.values.front();
    }
  }
}

std::string OptionTable::CanonicalText(const DigestFn& digest) const {
  std::map<std::string, std::string> lines;
  for (const auto& f : fields_) {
    if (!f.in_key() || f.path_role() == PathRole::kOutput) continue;
    std::string value = f.ValueText();
    // A missing input names the option that points at it.
    auto keyed_digest = [&](const std::string& path) -> std::string {
      std::error_code ec;
      if (f.path_role() == PathRole::kInputDir && fs::is_regular_file(path, ec)) {
        RELIGHT_USER_ERROR() << section_ << "." << f.name() << ": '" << path
                             << "' is a file, not a folder; set it to the folder that holds the files";
      }
      if (f.path_role() == PathRole::kInputFile && fs::is_directory(path, ec)) {
        RELIGHT_USER_ERROR() << section_ << "." << f.name() << ": '" << path
                             << "' is a folder, not a file; name the file itself (" << f.doc() << ")";
      }
      try {
        return digest(path, f.selection());
      } catch (const UserError& e) {
        throw UserError(section_ + "." + f.name() + ": " + e.what());
      }
    };
    if (f.is_input_path()) {
      if (std::holds_alternative<std::vector<std::string>*>(f.target())) {
        std::vector<std::string> digests;
        for (const auto& p : f.PathValues()) digests.push_back("sha256:" + keyed_digest(p));
        value = "[" + JoinStrings(digests, ", ") + "]";
      } else {
        value = f.StringValue().empty() ? "<none>" : "sha256:" + keyed_digest(f.StringValue());
      }
    }
    lines[section_ + "." + f.name()] = value;
  }
  std::string out;
  for (const auto& [k, v] : lines) out += k + "=" + v + "\n";
  return out;
}

YAML::Node OptionTable::ToYaml() const {
  YAML::Node node(YAML::NodeType::Map);
  for (const auto& f : fields_) f.ToYaml(&node);
  return node;
}

namespace {

// One markdown table row of `f` in `section`.
std::string MarkdownRow(const std::string& section, const OptionField& f) {
  std::vector<std::string> allowed;
  for (const std::string& part : {f.ConstraintText(), f.ConditionText()})
    if (!part.empty()) allowed.push_back(part);
  if (!f.in_key()) allowed.push_back("not in cache key");
  const std::string def = f.default_text().empty() ? "\"\"" : f.default_text();
  return "| `" + section + "." + f.name() + "` | " + f.TypeName() + " | `" + def + "` | " + JoinStrings(allowed, "; ") +
         " | " + f.doc() + " |\n";
}

constexpr const char* kMarkdownHeader = "| key | type | default | allowed | description |\n|---|---|---|---|---|\n";

}  // namespace

std::string OptionTable::MarkdownReference() const {
  std::string public_rows, advanced_rows;
  for (const auto& f : fields_) {
    if (f.tier() == OptionField::Tier::kPublic) public_rows += MarkdownRow(section_, f);
    if (f.tier() == OptionField::Tier::kAdvanced) advanced_rows += MarkdownRow(section_, f);
  }
  std::string out = public_rows.empty() ? "" : kMarkdownHeader + public_rows;
  if (!advanced_rows.empty()) {
    out += (out.empty() ? "" : "\n") + std::string("#### ") + section_ + " — advanced\n\n" + kMarkdownHeader +
           advanced_rows;
  }
  return out;
}

std::string OptionTable::MarkdownExperimentalRows() const {
  std::string rows;
  for (const auto& f : fields_)
    if (f.tier() == OptionField::Tier::kExperimental) rows += MarkdownRow(section_, f);
  return rows;
}

std::vector<std::string> OptionTable::ExperimentalInUse() const {
  std::vector<std::string> names;
  for (const auto& f : fields_)
    if (f.tier() == OptionField::Tier::kExperimental && !f.is_default()) names.push_back(section_ + "." + f.name());
  return names;
}

std::string OptionTable::HelpText() const {
  std::ostringstream out;
  out << "Options (config section '" << section_ << "', or --set " << section_ << ".NAME=VALUE):\n";
  const std::pair<OptionField::Tier, const char*> groups[] = {
      {OptionField::Tier::kPublic, ""},
      {OptionField::Tier::kAdvanced, "Advanced options:\n"},
      {OptionField::Tier::kExperimental,
       "Measurement switches (for tests and docs/RESULTS.md; not for production runs):\n"}};
  for (const auto& [tier, title] : groups) {
    bool first = true;
    for (const auto& f : fields_) {
      if (f.tier() != tier) continue;
      if (first) out << title;
      first = false;
      std::string def = f.default_text().empty() ? "\"\"" : f.default_text();
      out << "  " << section_ << "." << f.name() << " (" << f.TypeName() << ", default " << def << ")";
      std::vector<std::string> constraints;
      for (const std::string& part : {f.ConstraintText(), f.ConditionText()})
        if (!part.empty()) constraints.push_back(part);
      if (!constraints.empty()) out << " [" << JoinStrings(constraints, "; ") << "]";
      out << "\n      " << f.doc() << "\n";
    }
  }
  return out.str();
}

}  // namespace relight
