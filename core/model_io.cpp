#include "core/model_io.hpp"

#include <fmt/format.h>
#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "brakefit/version.hpp"

namespace brakefit {

using nlohmann::json;

std::string sha256_hex(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr);
  std::string s = "sha256:";
  for (unsigned int i = 0; i < len; ++i) s += fmt::format("{:02x}", md[i]);
  return s;
}

namespace {

json matrix_to_json(const Eigen::MatrixXd& m) {
  json rows = json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    std::vector<double> r(static_cast<std::size_t>(m.cols()));
    for (Eigen::Index k = 0; k < m.cols(); ++k) r[static_cast<std::size_t>(k)] = m(i, k);
    rows.push_back(r);
  }
  return rows;
}

Eigen::RowVectorXd row_from(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::RowVectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

json body_of(const Model& m) {
  json som;
  som["rows"] = m.som.lattice().rows();
  som["cols"] = m.som.lattice().cols();
  som["codebook"] = matrix_to_json(m.som.codebook());
  som["unit_hits"] = m.unit_hits;
  json labels = json::array();
  for (const auto& p : m.unit_labels) labels.push_back({p.B, p.C, p.D, p.E});
  som["unit_labels"] = labels;
  som["qe"] = m.som_qe;
  som["te"] = m.som_te;
  json mlp;
  mlp["layers"] = m.mlp.front().layers();
  json nets = json::array();
  for (std::size_t k = 0; k < m.mlp.size(); ++k) {
    const Eigen::VectorXd w = m.mlp[k].parameters();
    const mlp::TrainReport& r = m.mlp_report[k];
    nets.push_back({{"parameters", std::vector<double>(w.data(), w.data() + w.size())},
                    {"report",
                     {{"epochs", r.epochs},
                      {"best_epoch", r.best_epoch},
                      {"train_mse", r.train_mse},
                      {"validation_mse", r.validation_mse},
                      {"early_stopped", r.early_stopped}}}});
  }
  auto vec = [](const Eigen::RowVectorXd& v) {
    return std::vector<double>(v.data(), v.data() + v.size());
  };
  mlp["input_mean"] = vec(m.mlp_in.mean);
  mlp["input_scale"] = vec(m.mlp_in.scale);
  mlp["output_mean"] = vec(m.mlp_out.mean);
  mlp["output_scale"] = vec(m.mlp_out.scale);
  mlp["networks"] = nets;
  json body;
  body["schema"] = kModelSchema;
  body["format_version"] = kModelFormatVersion;
  body["brakefit_version"] = kVersion;
  body["config_toml"] = format_train_config(m.config);
  body["grid"] = m.grid;
  body["som"] = som;
  body["mlp"] = mlp;
  return body;
}

}  // namespace

std::string serialize_model(Model& m) {
  json body = body_of(m);
  m.hash = sha256_hex(body.dump());
  body["checksum"] = m.hash;
  return body.dump(1) + "\n";
}

std::string resign_model_text(std::string_view text) {
  json body;
  try {
    body = json::parse(text);
  } catch (const json::exception& e) {
    throw InputError(fmt::format("not JSON: {}", e.what()));
  }
  if (!body.is_object()) throw InputError("not a JSON object");
  body.erase("checksum");
  body["checksum"] = sha256_hex(body.dump());
  return body.dump(1);
}

Model deserialize_model(std::string_view text, const std::string& source) {
  auto fail = [&](const std::string& msg) {
    return InputError(fmt::format("{}: {}", source, msg));
  };
  json body;
  try {
    body = json::parse(text);
  } catch (const json::parse_error& e) {
    throw fail(fmt::format("not a brakefit model (corrupt or truncated JSON at byte {})", e.byte));
  } catch (const json::exception& e) {  // e.g. a number beyond double (1e999)
    throw fail(fmt::format("not a brakefit model: {}", e.what()));
  }
  if (!body.is_object() || !body.contains("schema") || body["schema"] != kModelSchema)
    throw fail(fmt::format("not a brakefit model (schema is not '{}')", kModelSchema));
  if (!body.contains("format_version") || !body["format_version"].is_number_integer() ||
      body["format_version"].get<int>() != kModelFormatVersion)
    throw fail(
        fmt::format("model format version {} is not supported (this brakefit reads {})",
                    body.contains("format_version") ? body["format_version"].dump() : "missing",
                    kModelFormatVersion));
  if (!body.contains("checksum") || !body["checksum"].is_string())
    throw fail("model has no checksum");
  const std::string stored = body["checksum"].get<std::string>();
  body.erase("checksum");
  const std::string actual = sha256_hex(body.dump());
  if (stored != actual)
    throw fail("model is corrupt: checksum mismatch (the file was changed after training)");
  Model m;
  m.hash = actual;
  try {
    m.config =
        parse_train_config(body.at("config_toml").get<std::string>(), source + " (config_toml)");
    m.grid = body.at("grid").get<std::vector<double>>();
    if (m.grid != default_slip_grid())
      throw fail("model slip grid does not match this brakefit's grid (retrain the model)");
    const json& s = body.at("som");
    const auto rows = s.at("rows").get<std::size_t>(), cols = s.at("cols").get<std::size_t>();
    if (rows < 1 || cols < 1 || rows > 1000 || cols > 1000)
      throw fail(fmt::format("SOM of {} x {} units (1 to 1000 each way)", rows, cols));
    const auto cb = s.at("codebook").get<std::vector<std::vector<double>>>();
    if (cb.size() != rows * cols) throw fail("SOM codebook size does not match rows x cols");
    Eigen::MatrixXd codebook(static_cast<Eigen::Index>(cb.size()),
                             static_cast<Eigen::Index>(m.grid.size()));
    for (std::size_t i = 0; i < cb.size(); ++i) {
      if (cb[i].size() != m.grid.size())
        throw fail("SOM codebook dimension does not match the slip grid");
      codebook.row(static_cast<Eigen::Index>(i)) = row_from(cb[i]);
    }
    m.som = som::Som(som::HexLattice(rows, cols), std::move(codebook));
    m.unit_hits = s.at("unit_hits").get<std::vector<std::size_t>>();
    const auto labels = s.at("unit_labels").get<std::vector<std::array<double, 4>>>();
    if (m.unit_hits.size() != cb.size() || labels.size() != cb.size())
      throw fail("SOM labels do not match the map size");
    if (std::none_of(m.unit_hits.begin(), m.unit_hits.end(), [](std::size_t h) { return h > 0; }))
      throw fail("SOM has no unit with training hits (no unit can identify a curve)");
    for (const auto& l : labels) {
      if (!std::all_of(l.begin(), l.end(), [](double v) { return std::isfinite(v); }))
        throw fail("SOM unit label is not finite");
      m.unit_labels.push_back(MfParams{l[0], l[1], l[2], l[3], 0, 0});
    }
    m.som_qe = s.at("qe").get<double>();
    m.som_te = s.at("te").get<double>();
    const json& n = body.at("mlp");
    const auto layers = n.at("layers").get<std::vector<std::size_t>>();
    if (layers.size() < 2 || layers.size() > 16 || layers.front() != m.grid.size() + 1 ||
        layers.back() != 3)
      throw fail("MLP layer sizes do not match the slip grid and the 3 outputs");
    for (auto l : layers)
      if (l < 1 || l > 4096) throw fail("MLP layer of 0 or more than 4096 units");
    // An ensemble ("networks") or, as models of one network were written, its fields in "mlp".
    const json nets = n.contains("networks") ? n.at("networks") : json::array({n});
    if (!nets.is_array() || nets.empty() || nets.size() > 64)
      throw fail("MLP networks: expected an array of 1 to 64 networks");
    for (const json& one : nets) {
      mlp::Network net(layers, 0);
      const auto w = one.at("parameters").get<std::vector<double>>();
      if (w.size() != net.parameter_count())
        throw fail("MLP parameter count does not match its layers");
      if (!std::all_of(w.begin(), w.end(), [](double v) { return std::isfinite(v); }))
        throw fail("MLP parameter is not finite");
      net.set_parameters(
          Eigen::Map<const Eigen::VectorXd>(w.data(), static_cast<Eigen::Index>(w.size())));
      m.mlp.push_back(std::move(net));
      const json& r = one.at("report");
      mlp::TrainReport rep;
      rep.epochs = r.at("epochs").get<std::size_t>();
      rep.best_epoch = r.at("best_epoch").get<std::size_t>();
      rep.train_mse = r.at("train_mse").get<double>();
      rep.validation_mse = r.at("validation_mse").get<double>();
      rep.early_stopped = r.at("early_stopped").get<bool>();
      m.mlp_report.push_back(rep);
    }
    m.mlp_in = {row_from(n.at("input_mean").get<std::vector<double>>()),
                row_from(n.at("input_scale").get<std::vector<double>>())};
    m.mlp_out = {row_from(n.at("output_mean").get<std::vector<double>>()),
                 row_from(n.at("output_scale").get<std::vector<double>>())};
    if (m.mlp_in.mean.size() != static_cast<Eigen::Index>(layers.front()) ||
        m.mlp_in.scale.size() != m.mlp_in.mean.size() || m.mlp_out.mean.size() != 3 ||
        m.mlp_out.scale.size() != 3)
      throw fail("MLP scaler sizes do not match the network");
  } catch (const json::exception& e) {
    throw fail(fmt::format("model is missing or has a malformed field: {}", e.what()));
  }
  return m;
}

}  // namespace brakefit
