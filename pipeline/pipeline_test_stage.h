// Options of the small test stages that exercise the orchestrator
// (alpha -> beta, alpha -> gamma, beta + gamma -> delta).
#pragma once

#include <string>

#include "core/options.h"

namespace relight::pipeline {

struct TestStageOptions {
  int value = 1;         // Result contribution of this stage.
  int items = 3;         // Per-item outputs (to test per-item resume).
  int sleep_ms = 0;      // Time spent per item.
  bool fail = false;     // Exit with a user error.
  std::string input;     // Optional raw input file (content enters the key).
  std::string note;      // Not in the key.
  int memory_mib = 0;    // Memory to allocate and touch (to test the peak-memory record).

  void Declare(OptionTable* t) {
    t->Add("value", &value, "Result contribution.");
    t->Add("items", &items, "Per-item outputs.").Min(0);
    t->Add("sleep_ms", &sleep_ms, "Milliseconds per item.").Min(0).NotInKey();
    t->Add("fail", &fail, "Fail with a user error.");
    t->Add("input", &input, "Raw input file.").InputFile();
    t->Add("note", &note, "Free text, not in the key.").NotInKey();
    t->Add("memory_mib", &memory_mib, "MiB to allocate and touch.").Min(0);
  }
  void Check() const {}
};

}  // namespace relight::pipeline
