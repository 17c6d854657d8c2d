// What the benchmarks report their figures with: the median of a run's samples (they quote medians,
// not one run).
#pragma once

#include <algorithm>
#include <vector>

namespace strata::bench {

// The middle sample, or the mean of the middle two; 0 without samples.
inline double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace strata::bench
