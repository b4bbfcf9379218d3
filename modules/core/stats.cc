#include "core/stats.h"

#include <algorithm>
#include <cmath>

namespace relight {

double Mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? 0.0 : sum / values.size();
}

double Percentile(std::vector<double>* v, double p) {
  if (v->empty()) return 0.0;
  const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * (v->size() - 1);
  const size_t k = static_cast<size_t>(std::floor(pos));
  std::nth_element(v->begin(), v->begin() + k, v->end());
  double value = (*v)[k];
  if (k + 1 < v->size() && pos > k) {
    const double next = *std::min_element(v->begin() + k + 1, v->end());
    value += (pos - k) * (next - value);
  }
  return value;
}

}  // namespace relight
