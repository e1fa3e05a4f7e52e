#pragma once
// What the referee's parts share: quantiles of a sample, and a map over trials on threads with
// progress on stderr.
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <exception>
#include <functional>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace brakefit::bench {

/// Lines under a miss on stderr, indented (a trial's notes, its candidates' scores).
inline void print_indented(const std::vector<std::string>& lines) {
  for (const auto& line : lines) std::cerr << "    " << line << "\n";
}

inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

/// results[i] = f(i) for i < n on `threads` threads, with progress every 20 done. The first
/// exception f throws stops the other workers at their next item and is rethrown here.
template <class T>
std::vector<T> parallel_map(int n, int threads, const std::function<T(int)>& f,
                            const std::string& what) {
  std::vector<T> out(static_cast<std::size_t>(std::max(0, n)));
  std::atomic<int> next{0}, done{0};
  std::mutex log;
  std::exception_ptr failed;
  auto worker = [&] {
    try {
      for (int i = next++; i < n; i = next++) {
        out[static_cast<std::size_t>(i)] = f(i);
        const int d = ++done;
        if (d % 20 == 0 || d == n) {
          std::lock_guard lock(log);
          std::cerr << fmt::format("  {}: {}/{}\n", what, d, n);
        }
      }
    } catch (...) {
      std::lock_guard lock(log);
      if (!failed) failed = std::current_exception();
      next = n;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  if (failed) std::rethrow_exception(failed);
  return out;
}

}  // namespace brakefit::bench
