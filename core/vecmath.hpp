#pragma once
// atan, sin, exp and log over an array in place. The gap diagnosis evaluates the Magic Formula on
// every sample of every run for every trial parameter vector: its two arctangents and one sine are
// most of a diagnosis's time. glibc's vector math library (libmvec) computes four at once on a CPU
// with AVX2 and FMA, within 4 ulp of the scalar functions; elsewhere the scalar std:: functions
// run. Results may therefore differ in the last bits between machines with and without AVX2.
#include <span>

namespace brakefit {

void atan_in_place(std::span<double> x);
void sin_in_place(std::span<double> x);
void exp_in_place(std::span<double> x);
void log_in_place(std::span<double> x);  ///< x > 0

/// True where the vector path runs (a CPU with AVX2 and FMA).
bool vector_math_available();

}  // namespace brakefit
