#include "core/vecmath.hpp"

#include <cmath>
#include <cstddef>

namespace brakefit {

#ifdef BRAKEFIT_VECMATH_AVX2
namespace detail {
// core/vecmath_avx2.cpp, compiled for AVX2 and FMA: called only where the CPU has both.
void atan_avx2(double* x, std::size_t n);
void sin_avx2(double* x, std::size_t n);
void exp_avx2(double* x, std::size_t n);
void log_avx2(double* x, std::size_t n);
}  // namespace detail

bool vector_math_available() {
  static const bool available = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  }();
  return available;
}
#else
namespace detail {
inline void atan_avx2(double*, std::size_t) {}
inline void sin_avx2(double*, std::size_t) {}
inline void exp_avx2(double*, std::size_t) {}
inline void log_avx2(double*, std::size_t) {}
}  // namespace detail

bool vector_math_available() {
  return false;
}
#endif

namespace {

void apply(std::span<double> x, void (*vec)(double*, std::size_t), double (*scalar)(double)) {
  if (vector_math_available()) return vec(x.data(), x.size());
  for (double& v : x) v = scalar(v);
}

}  // namespace

void atan_in_place(std::span<double> x) {
  apply(x, detail::atan_avx2, [](double v) { return std::atan(v); });
}
void sin_in_place(std::span<double> x) {
  apply(x, detail::sin_avx2, [](double v) { return std::sin(v); });
}
void exp_in_place(std::span<double> x) {
  apply(x, detail::exp_avx2, [](double v) { return std::exp(v); });
}
void log_in_place(std::span<double> x) {
  apply(x, detail::log_avx2, [](double v) { return std::log(v); });
}

}  // namespace brakefit
