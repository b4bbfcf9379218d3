#include "pipeline/stage_graph.h"

#include "core/error.h"

namespace relight::pipeline {

ResolvedConfig::ResolvedConfig(const ConfigDocument& doc, const std::vector<StageDef>& stages) : doc_(doc) {
  std::vector<std::string> known{"pipeline"};
  for (const auto& s : stages) known.push_back(s.name());
  doc_.CheckSections(known);
  pipeline_table_ = std::make_unique<OptionTable>(MakeOptionTable("pipeline", &pipeline_));
  doc_.Apply(pipeline_table_.get());
  for (const auto& s : stages) {
    auto holder = s.make_options();
    doc_.Apply(&holder->table());
    try {
      holder->Check();
    } catch (const UserError& e) {
      RELIGHT_USER_ERROR() << (doc_.path().empty() ? "options" : doc_.path()) << ": stage '" << s.name()
                           << "': " << e.what();
    }
    options_[s.name()] = std::move(holder);
  }
}

StageOptionsHolder& ResolvedConfig::options(const std::string& stage) const {
  auto it = options_.find(stage);
  RELIGHT_CHECK(it != options_.end()) << "no stage named " << stage;
  return *it->second;
}

}  // namespace relight::pipeline
