#pragma once
// sysexits-style exit codes shared by `brakefit` and `brakefitd`, and the error that carries one.
#include <stdexcept>
#include <string>

namespace brakefit {

inline constexpr int kExitDataError = 65;    ///< bad data or model file
inline constexpr int kExitNoInput = 66;      ///< missing input
inline constexpr int kExitUnavailable = 69;  ///< a configured source is absent
inline constexpr int kExitOsErr = 71;        ///< cannot listen
inline constexpr int kExitCantCreate = 73;   ///< cannot write / open the store
inline constexpr int kExitConfig = 78;       ///< bad configuration

struct ExitError : std::runtime_error {
  ExitError(int code_, const std::string& msg) : std::runtime_error(msg), code(code_) {}
  int code;
};

}  // namespace brakefit
