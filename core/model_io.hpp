#pragma once
// Model file: versioned JSON text {"schema":"brakefit.model/1", "format_version", "config" (the
// training TOML), "grid", "som", "mlp", "checksum":"sha256:..."}. The checksum covers the canonical
// body; it is also the model hash reported in every result (provenance). Pure: text in, text out.
#include <string>
#include <string_view>

#include "core/identify.hpp"

namespace brakefit {

inline constexpr int kModelFormatVersion = 1;
inline constexpr const char* kModelSchema = "brakefit.model/1";

/// Serialises the model and sets m.hash.
std::string serialize_model(Model& m);
/// Throws InputError naming the source for corrupt, truncated or mismatched files.
/// Re-signs a model's JSON text (its checksum recomputed): for tests and the fuzzer, which change
/// a model on purpose to reach the checks behind the checksum. Throws InputError on bad JSON.
std::string resign_model_text(std::string_view text);
Model deserialize_model(std::string_view text, const std::string& source);
/// "sha256:<hex>" of the bytes.
std::string sha256_hex(std::string_view bytes);

}  // namespace brakefit
