#include "core/tyre/tir_numbers.hpp"

#include <fmt/format.h>

#include "core/curve.hpp"

namespace brakefit::tyre {

Mf61Tyre tyre_from_tir(const TirNumbers& numbers, const std::string& source) {
  auto find = [&](const std::string& section, const std::string& key) -> const double* {
    const auto s = numbers.find(section);
    if (s == numbers.end()) return nullptr;
    const auto k = s->second.find(key);
    return k == s->second.end() ? nullptr : &k->second;
  };
  auto get = [&](const std::string& section, const std::string& key, double fallback) {
    const double* v = find(section, key);
    return v ? *v : fallback;
  };
  auto need = [&](const std::string& section, const std::string& key) {
    const double* v = find(section, key);
    if (!v) throw InputError(fmt::format("{}: [{}] {} missing", source, section, key));
    return *v;
  };
  const std::string scaling = "SCALING_COEFFICIENTS", longitudinal = "LONGITUDINAL_COEFFICIENTS";
  Mf61Tyre t;
  t.ref.fnomin_n = need("VERTICAL", "FNOMIN");
  t.ref.nompres_pa = get("OPERATING_CONDITIONS", "NOMPRES", t.ref.nompres_pa);
  t.ref.longvl_mps = get("MODEL", "LONGVL", t.ref.longvl_mps);
  t.ref.lfzo = get(scaling, "LFZO", 1);
  t.ref.lcx = get(scaling, "LCX", 1);
  t.ref.lmux = get(scaling, "LMUX", 1);
  t.ref.lex = get(scaling, "LEX", 1);
  t.ref.lkx = get(scaling, "LKX", 1);
  t.ref.lhx = get(scaling, "LHX", 1);
  t.ref.lvx = get(scaling, "LVX", 1);
  for (std::size_t i = 0; i < kCoefCount; ++i) {
    const std::string name(coef_name(i));
    if (name == "LMUV")  // a scaling in the file, a coefficient of the fit
      t.coef[i] = get(scaling, name, 0);
    else if (name == "PCX1" || name == "PDX1" || name == "PKX1")
      t.coef[i] = need(longitudinal, name);
    else
      t.coef[i] = get(longitudinal, name, 0);
  }
  return t;
}

}  // namespace brakefit::tyre
