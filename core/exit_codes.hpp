#pragma once
// sysexits-style exit codes shared by `brakefit` and `brakefitd`, and the error that carries one.
#include <stdexcept>
#include <string>

namespace brakefit {

// The one table (README "Exit codes"): 0 ok, 64 usage, 65 data, 66 no input, 69 unavailable,
// 70 internal error, 71 cannot listen, 73 cannot create or write, 75 try again later (brakefitd:
// another instance holds the store), 78 configuration.
inline constexpr int kExitUsage = 64;        ///< wrong arguments or options
inline constexpr int kExitDataError = 65;    ///< bad data or model file
inline constexpr int kExitNoInput = 66;      ///< missing input
inline constexpr int kExitUnavailable = 69;  ///< a configured source is absent
inline constexpr int kExitSoftware = 70;     ///< internal error (a bug: please report it)
inline constexpr int kExitOsErr = 71;        ///< cannot listen
inline constexpr int kExitCantCreate = 73;   ///< cannot write / open the store
inline constexpr int kExitTempFail = 75;     ///< brakefitd: another instance holds the store
inline constexpr int kExitConfig = 78;       ///< bad configuration

struct ExitError : std::runtime_error {
  ExitError(int code_, const std::string& msg) : std::runtime_error(msg), code(code_) {}
  int code;
};

}  // namespace brakefit
