// Compiled with -mavx2 -mfma (core/CMakeLists.txt); reached only through core/vecmath.cpp's
// check of the CPU. libmvec's 4-lane AVX2 variants by their vector-ABI names.
#include <immintrin.h>

#include <algorithm>
#include <cstddef>

// The vector-function ABI names libmvec exports (glibc declares them only under -ffast-math).
// NOLINTBEGIN(bugprone-reserved-identifier)
extern "C" {
__m256d _ZGVdN4v_atan(__m256d x);
__m256d _ZGVdN4v_sin(__m256d x);
__m256d _ZGVdN4v_exp(__m256d x);
__m256d _ZGVdN4v_log(__m256d x);
}
// NOLINTEND(bugprone-reserved-identifier)

namespace brakefit::detail {

namespace {

template <__m256d (*F)(__m256d)>
void apply(double* x, std::size_t n) {
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) _mm256_storeu_pd(x + i, F(_mm256_loadu_pd(x + i)));
  if (i == n) return;
  // The last one to three values through a padded lane set (ones are in every domain).
  alignas(32) double tail[4] = {1, 1, 1, 1};
  std::copy(x + i, x + n, tail);
  _mm256_store_pd(tail, F(_mm256_load_pd(tail)));
  std::copy(tail, tail + (n - i), x + i);
}

}  // namespace

void atan_avx2(double* x, std::size_t n) {
  apply<_ZGVdN4v_atan>(x, n);
}
void sin_avx2(double* x, std::size_t n) {
  apply<_ZGVdN4v_sin>(x, n);
}
void exp_avx2(double* x, std::size_t n) {
  apply<_ZGVdN4v_exp>(x, n);
}
void log_avx2(double* x, std::size_t n) {
  apply<_ZGVdN4v_log>(x, n);
}

}  // namespace brakefit::detail
