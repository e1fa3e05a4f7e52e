#include "core/gap/predict_cache.hpp"

namespace brakefit::gap {

const std::vector<double>& PredictCache::get(const Run& r, Kind kind, double a, double b,
                                             const std::function<std::vector<double>()>& make) {
  std::vector<Entry>& entries = runs_[&r];
  // Never reallocated: a value handed out stays where it is until its own kind's entry is reused.
  if (entries.capacity() == 0) entries.reserve(kPerKind * kKinds);
  ++clock_;
  Entry* oldest = nullptr;
  std::size_t of_kind = 0;
  for (Entry& e : entries) {
    if (e.kind != kind) continue;
    // Exact equality: a value is reused only where the computation would be asked the same.
    if (e.a == a && e.b == b) {
      e.used = clock_;
      return e.values;
    }
    ++of_kind;
    if (!oldest || e.used < oldest->used) oldest = &e;
  }
  if (of_kind < kPerKind || !oldest) {
    entries.push_back(Entry{kind, a, b, make(), clock_});
    return entries.back().values;
  }
  oldest->a = a;
  oldest->b = b;
  oldest->values = make();
  oldest->used = clock_;
  return oldest->values;
}

}  // namespace brakefit::gap
