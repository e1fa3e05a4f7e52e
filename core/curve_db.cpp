#include "core/curve_db.hpp"

#include <fmt/format.h>

#include "core/curve.hpp"
#include "core/rng.hpp"

namespace brakefit {

DatabaseSettings database_preset(const std::string& name) {
  DatabaseSettings s;
  s.preset = name;
  if (name == "default") {
    // Passenger car at nominal load: C 1.55-1.65, B 9.6-22, E -0.05..0.6, D = mu*Fz with
    // mu 1.0-1.26 and Fz 2-6 kN. Truck: C 1.35-1.45, B 4-8, E -6..-1, Fz 15-35 kN, mu 0.8-1.0.
    s.families = {
        {"car", 0.8, {9.6, 22.0}, {1.55, 1.65}, {2000.0, 7500.0}, {-0.05, 0.6}},
        {"truck", 0.2, {4.0, 8.0}, {1.35, 1.45}, {12000.0, 35000.0}, {-6.0, -1.0}},
    };
  } else if (name == "paper") {
    s.families = {{"paper", 1.0, {25.0, 60.0}, {0.9, 1.1}, {800.0, 2400.0}, {30.0, 50.0}}};
  } else {
    throw InputError(fmt::format("unknown database preset '{}' (known: default, paper)", name));
  }
  return s;
}

MfParams draw_params(const DatabaseSettings& s, Rng& rng, std::size_t* family_index) {
  double total = 0.0;
  for (const auto& f : s.families) total += f.weight;
  double pick = rng.uniform() * total;
  std::size_t fi = 0;
  for (; fi + 1 < s.families.size(); ++fi) {
    if (pick < s.families[fi].weight) break;
    pick -= s.families[fi].weight;
  }
  const TyreFamily& f = s.families[fi];
  MfParams p;
  p.B = rng.uniform(f.B.lo, f.B.hi);
  p.C = rng.uniform(f.C.lo, f.C.hi);
  p.D = rng.uniform(f.D_n.lo, f.D_n.hi);
  p.E = rng.uniform(f.E.lo, f.E.hi);
  if (family_index) *family_index = fi;
  return p;
}

CurveDatabase generate_database(const DatabaseSettings& s, const std::vector<double>& grid) {
  CurveDatabase db;
  db.grid = grid;
  const auto n = static_cast<Eigen::Index>(s.n_curves);
  const auto g = static_cast<Eigen::Index>(grid.size());
  db.forces_n.resize(n, g);
  db.labels.reserve(s.n_curves);
  db.family.reserve(s.n_curves);
  Rng rng(s.seed);
  for (Eigen::Index i = 0; i < n; ++i) {
    std::size_t fi = 0;
    const MfParams p = draw_params(s, rng, &fi);
    for (Eigen::Index k = 0; k < g; ++k)
      db.forces_n(i, k) = mf_force_n(p, grid[static_cast<std::size_t>(k)]);
    db.labels.push_back(p);
    db.family.push_back(fi);
  }
  return db;
}

}  // namespace brakefit
