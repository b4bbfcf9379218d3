// Summary statistics of samples: one definition for every module and tool.
#pragma once

#include <vector>

namespace relight {

// Arithmetic mean; 0 for no samples.
double Mean(const std::vector<double>& values);

// The p-th percentile (p in [0, 100], clamped) with linear interpolation between the closest ranks
// (NumPy's default): rank p/100 * (n - 1) of the sorted values. 0 for no samples. Reorders `values`.
double Percentile(std::vector<double>* values, double p);
// The same on a copy.
inline double PercentileOf(std::vector<double> values, double p) { return Percentile(&values, p); }

// Percentile 50: the middle value, or the mean of the two middle values.
inline double Median(std::vector<double> values) { return Percentile(&values, 50); }

}  // namespace relight
