#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "tests/unit/test_util.hpp"

#include "core/curve_csv.hpp"
#include "core/model_io.hpp"
#include "core/toml_reader.hpp"
#include "core/train.hpp"

using namespace brakefit;

namespace {

TrainConfig tiny_config() {
  TrainConfig c;
  c.database.n_curves = 300;
  c.som.rows = 5;
  c.som.cols = 5;
  c.som.rough.epochs = 30;
  c.som.fine.epochs = 20;
  c.mlp.hidden = {8};
  c.mlp.max_epochs = 60;
  return c;
}

const Model& tiny_model() {
  static Model m = [] {
    Model t = train_model(tiny_config());
    serialize_model(t);
    return t;
  }();
  return m;
}

std::string load_error(const std::string& text) {
  try {
    deserialize_model(text, "m.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(TrainConfig, ShippedConfigEqualsBuiltInDefaultsAndRoundTrips) {
  const std::string path = brakefit::test::source_path("config/train.toml");
  const TrainConfig shipped = parse_train_config(brakefit::test::read_text(path), path);
  const TrainConfig builtin;
  EXPECT_EQ(format_train_config(shipped), format_train_config(builtin));
  const TrainConfig again = parse_train_config(format_train_config(shipped), "round-trip");
  EXPECT_EQ(format_train_config(again), format_train_config(shipped));
  const std::string paper = brakefit::test::source_path("config/train-paper.toml");
  const TrainConfig p = parse_train_config(brakefit::test::read_text(paper), paper);
  EXPECT_EQ(p.database.preset, "paper");
  EXPECT_EQ(p.som_input, SomInput::Raw);
  EXPECT_DOUBLE_EQ(p.database.families.at(0).E.hi, 50.0);
}

TEST(TrainConfig, ErrorsNameTheKey) {
  auto err = [](const std::string& t) {
    try {
      parse_train_config(t, "t.toml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(err("[som]\nrowz = 3\n").rfind("t.toml: key 'som.rowz': unknown key", 0), 0u);
  EXPECT_EQ(err("[som]\nrows = \"ten\"\n").rfind("t.toml: key 'som.rows': expected an integer", 0),
            0u);
  EXPECT_EQ(err("[som]\nrows = 1\n").rfind("t.toml: key 'som.rows': value 1 is outside", 0), 0u);
  EXPECT_EQ(err("[som]\nneighbourhood = \"mexican\"\n").rfind("t.toml: key 'som.neighbourhood'", 0),
            0u);
  EXPECT_EQ(err("[mlp]\ntrainer = \"adam\"\n").rfind("t.toml: key 'mlp.trainer'", 0), 0u);
  EXPECT_EQ(err("[database]\npreset = \"bus\"\n").rfind("t.toml: key 'database.preset'", 0), 0u);
  EXPECT_EQ(err("[[database.family]]\nB = [1, 2]\nC = [1, 2]\nD_n = [1]\nE = [0, 1]\n")
                .rfind("t.toml: key 'database.family[0].D_n': expected exactly two", 0),
            0u);
  EXPECT_EQ(err("[som\n").rfind("t.toml:1:", 0), 0u);
}

TEST(Database, DeterministicFromSeedAndInsideTheRanges) {
  const DatabaseSettings s = database_preset("default");
  const auto grid = default_slip_grid();
  const CurveDatabase a = generate_database(s, grid), b = generate_database(s, grid);
  EXPECT_TRUE(a.forces_n == b.forces_n);
  std::size_t trucks = 0;
  for (std::size_t i = 0; i < a.labels.size(); ++i) {
    const TyreFamily& f = s.families[a.family[i]];
    EXPECT_TRUE(f.B.contains(a.labels[i].B) && f.C.contains(a.labels[i].C) &&
                f.D_n.contains(a.labels[i].D) && f.E.contains(a.labels[i].E));
    trucks += a.family[i] == 1;
  }
  EXPECT_NEAR(static_cast<double>(trucks) / static_cast<double>(a.labels.size()), 0.2, 0.04);
  DatabaseSettings other = s;
  other.seed += 1;
  EXPECT_FALSE(generate_database(other, grid).forces_n == a.forces_n);
  EXPECT_THROW(database_preset("bus"), InputError);
}

TEST(Model, RoundTripKeepsEveryPredictionAndTheHash) {
  Model m = tiny_model();
  const std::string text = serialize_model(m);
  const Model back = deserialize_model(text, "m.json");
  EXPECT_EQ(back.hash, m.hash);
  EXPECT_EQ(back.hash.rfind("sha256:", 0), 0u);
  EXPECT_EQ(back.hash.size(), 7u + 64u);
  EXPECT_TRUE(back.som.codebook() == m.som.codebook());
  EXPECT_EQ(back.unit_hits, m.unit_hits);
  ASSERT_EQ(back.mlp.size(), m.config.mlp_ensemble);
  for (std::size_t k = 0; k < m.mlp.size(); ++k)
    EXPECT_TRUE(back.mlp[k].parameters() == m.mlp[k].parameters()) << k;
  const Curve c = sample_curve({14, 1.6, 4000, 0.2, 0, 0}, even_slips(100, 1.0));
  for (Method meth : {Method::Som, Method::Mlp, Method::Hybrid}) {
    const MethodResult r1 = run_method(meth, &m, c), r2 = run_method(meth, &back, c);
    EXPECT_EQ(to_array(r1.params), to_array(r2.params)) << to_string(meth);
  }
}

TEST(Model, TheMlpEstimateIsTheMeanOfItsNetworksAndAOneNetworkFileStillLoads) {
  const Model& m = tiny_model();
  ASSERT_GE(m.mlp.size(), 2u);
  const Curve c = sample_curve({14, 1.6, 4000, 0.2, 0, 0}, even_slips(100, 0.27));
  // Each network alone, as a model of one network.
  double log_b = 0.0, c_sum = 0.0, e_sum = 0.0;
  std::vector<double> bs;
  for (std::size_t k = 0; k < m.mlp.size(); ++k) {
    Model one = m;
    one.mlp = {m.mlp[k]};
    one.mlp_report = {m.mlp_report[k]};
    const MfParams p = identify_mlp(one, c);
    log_b += std::log(p.B);
    c_sum += p.C;
    e_sum += p.E;
    bs.push_back(p.B);
  }
  const auto n = static_cast<double>(m.mlp.size());
  const MfParams all = identify_mlp(m, c);
  EXPECT_NEAR(std::log(all.B), log_b / n, 1e-9);
  EXPECT_NEAR(all.C, c_sum / n, 1e-9);
  EXPECT_NEAR(all.E, e_sum / n, 1e-9);
  // The networks differ (their seeds), so the mean is not any one of them.
  EXPECT_GT(*std::max_element(bs.begin(), bs.end()) - *std::min_element(bs.begin(), bs.end()),
            1e-6);
  // A model file written with one network's fields directly in "mlp" loads as one network.
  Model written = m;
  nlohmann::json doc = nlohmann::json::parse(serialize_model(written));
  nlohmann::json& mlp = doc["mlp"];
  mlp["parameters"] = mlp["networks"][0]["parameters"];
  mlp["report"] = mlp["networks"][0]["report"];
  mlp.erase("networks");
  const Model legacy = deserialize_model(resign_model_text(doc.dump()), "legacy.json");
  ASSERT_EQ(legacy.mlp.size(), 1u);
  EXPECT_TRUE(legacy.mlp[0].parameters() == m.mlp[0].parameters());
  // An empty ensemble is an error that names the field.
  mlp["networks"] = nlohmann::json::array();
  EXPECT_NE(load_error(resign_model_text(doc.dump())).find("MLP networks"), std::string::npos);
}

TEST(Model, CorruptTruncatedAndMismatchedFilesGiveClearErrors) {
  Model m = tiny_model();
  const std::string text = serialize_model(m);
  // Change one digit of the codebook.
  std::string corrupt = text;
  const auto pos = corrupt.find("\"codebook\"");
  const auto digit = corrupt.find_first_of("123456789", pos + 20);
  corrupt[digit] = corrupt[digit] == '9' ? '8' : static_cast<char>(corrupt[digit] + 1);
  EXPECT_NE(load_error(corrupt).find("m.json: model is corrupt: checksum mismatch"),
            std::string::npos);
  EXPECT_NE(load_error(text.substr(0, text.size() / 2))
                .find("m.json: not a brakefit model (corrupt or truncated JSON"),
            std::string::npos);
  std::string v2 = text;
  v2.replace(v2.find("\"format_version\": 1"), 19, "\"format_version\": 2");
  EXPECT_NE(load_error(v2).find("model format version 2 is not supported"), std::string::npos);
  EXPECT_NE(load_error("{\"schema\": \"other\"}").find("schema is not 'brakefit.model/1'"),
            std::string::npos);
}

TEST(Identify, HybridRecoversAnInRangeCurveAndSomFallsBackFromEmptyUnits) {
  Model m = tiny_model();
  const MfParams truth{16, 1.6, 5000, 0.25, 0, 0};
  const Curve c = sample_curve(truth, even_slips(200, 1.0));
  const MethodResult h = run_method(Method::Hybrid, &m, c);
  EXPECT_NEAR(h.params.B, truth.B, 1e-6 * truth.B);
  EXPECT_NEAR(h.params.E, truth.E, 1e-6);
  EXPECT_LT(h.metrics.mape_pct, 1e-6);
  const MethodResult s = run_method(Method::Som, &m, c);
  EXPECT_LT(s.metrics.mape_pct, 5.0);  // a coarse 5x5 map, still in the right region
  // Empty the BMU's labels: identification falls back to the best labelled unit.
  const SomEstimate before = identify_som(m, c);
  ASSERT_FALSE(before.fallback);
  m.unit_hits[before.bmu] = 0;
  const SomEstimate after = identify_som(m, c);
  EXPECT_TRUE(after.fallback);
  EXPECT_NE(after.bmu, before.bmu);
  EXPECT_GT(m.unit_hits[after.bmu], 0u);
}

TEST(Identify, LeastSquaresBoundsCoverTheModelsDatabaseRanges) {
  EXPECT_DOUBLE_EQ(fit_options_for(nullptr).bounds.E_hi, 1.0);
  Model m = tiny_model();
  EXPECT_DOUBLE_EQ(fit_options_for(&m).bounds.E_hi, 1.0);  // default families stay inside E <= 1
  EXPECT_DOUBLE_EQ(fit_options_for(&m).bounds.E_lo, -20.0);
  m.config.database = database_preset("paper");
  EXPECT_DOUBLE_EQ(fit_options_for(&m).bounds.E_hi, 50.0);
  EXPECT_DOUBLE_EQ(fit_options_for(&m).bounds.B_hi, 200.0);
}

TEST(Identify, TheMlpFlagsACurveShorterThanAnyItWasTrainedOn) {
  Model m = tiny_model();
  const MfParams p{16, 1.6, 5000, 0.25, 0, 0};
  ASSERT_GT(m.config.mlp_truncate_fraction, 0.0);
  const double shortest = m.config.mlp_truncate_min_ratio;
  // A roller test to its 27 % switch-off, and a tyre's curve to just past its peak (11 %), are
  // inside what it saw; a curve stopped at 3 %, far short of the peak, is not.
  for (const double end : {0.27, 0.11})
    EXPECT_TRUE(
        run_method(Method::Mlp, &m, sample_curve(p, even_slips(100, end))).implausible.empty())
        << end;
  const MethodResult short_ = run_method(Method::Mlp, &m, sample_curve(p, even_slips(100, 0.03)));
  // (The tiny network's estimate there may also lie past its training's ranges: a second reason.)
  ASSERT_GE(short_.implausible.size(), 1u);
  EXPECT_NE(short_.implausible[0].find("MLP extrapolating: the curve ends at"), std::string::npos);
  EXPECT_NE(short_.implausible[0].find(fmt::format("{:.1f} %", 100 * shortest)), std::string::npos);
  // A curve cut exactly at the shortest cut is one the training made.
  EXPECT_TRUE(mlp_outside_training(m, sample_curve(p, even_slips(100, shortest))).empty());
  // The other methods are not judged by the MLP's training; plausibility reasons are added to it.
  EXPECT_TRUE(
      run_method(Method::Lm, &m, sample_curve(p, even_slips(100, 0.05))).implausible.empty());
  MethodResult flagged = short_;
  flagged.params.C = 0.3;
  flag_implausible(flagged, 3800.0);
  EXPECT_GE(flagged.implausible.size(), 2u);
  // A model whose cuts stop at 60 %: a ground run measured to 87 % ends where no training curve
  // did (a car's curve there came out E 2 from such a model); at the cut or the grid's end it is
  // one it saw.
  m.config.mlp_truncate_max_ratio = 0.6;
  const auto long_ = mlp_outside_training(m, sample_curve(p, even_slips(100, 0.87)));
  ASSERT_EQ(long_.size(), 1u);
  EXPECT_NE(long_[0].find("the curve ends at 85.0 % slip"), std::string::npos) << long_[0];
  EXPECT_NE(long_[0].find("cut at 60.0 % or shorter, or reaching 100.0 %"), std::string::npos)
      << long_[0];
  EXPECT_TRUE(mlp_outside_training(m, sample_curve(p, even_slips(100, 0.6))).empty());
  m.config.mlp_truncate_max_ratio = 1.0;
  EXPECT_TRUE(mlp_outside_training(m, sample_curve(p, even_slips(100, 0.87))).empty());
  // A model trained on whole curves only: anything short of the grid's end is an extrapolation.
  m.config.mlp_truncate_fraction = 0.0;
  EXPECT_FALSE(mlp_outside_training(m, sample_curve(p, even_slips(100, 0.27))).empty());
  EXPECT_TRUE(mlp_outside_training(m, sample_curve(p, even_slips(100, m.grid.back()))).empty());
}

TEST(Identify, AnMlpEstimatePastItsTrainingRangesIsFlagged) {
  const Model& m = tiny_model();
  // The default families: B 4-22, C 1.35-1.65, E -6 to 0.6 (car and truck).
  EXPECT_TRUE(mlp_estimate_outside_training(m, {15, 1.6, 5000, 0.3, 0, 0}).empty());
  // Within a tenth of a range's width past its end: an estimate rounding at the edge.
  EXPECT_TRUE(mlp_estimate_outside_training(m, {22.5, 1.66, 5000, 0.62, 0, 0}).empty());
  const auto e = mlp_estimate_outside_training(m, {15, 1.6, 5000, 1.5, 0, 0});
  ASSERT_EQ(e.size(), 1u);
  EXPECT_NE(e[0].find("MLP extrapolating: its E 1.5 lies outside the E"), std::string::npos)
      << e[0];
  EXPECT_NE(e[0].find("(-6 to 0.6)"), std::string::npos) << e[0];
  EXPECT_EQ(mlp_estimate_outside_training(m, {30, 1.9, 5000, 0.3, 0, 0}).size(), 2u);
  // A model without families (a hand-made one) has no ranges to judge by.
  Model bare = m;
  bare.config.database.families.clear();
  EXPECT_TRUE(mlp_estimate_outside_training(bare, {30, 1.9, 5000, 3, 0, 0}).empty());
}

TEST(Identify, ShapeScaleIsTheLinearLeastSquaresD) {
  const MfParams p{12, 1.55, 3333, 0.1, 0, 0};
  const Curve c = sample_curve(p, even_slips(40, 0.3));
  EXPECT_NEAR(fit_scale_D(c, p.B, p.C, p.E), 3333, 1e-8);
}

// Found by a hostile operator (issue 12): clear errors naming the file, never UB or "internal".
TEST(Model, HugeNumbersAndAnEmptyMapBehindAValidChecksumAreErrors) {
  EXPECT_NE(load_error("{\"schema\": 1e999}").find("m.json: not a brakefit model"),
            std::string::npos);
  Model m = tiny_model();
  const std::string text = serialize_model(m);
  auto edited = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const auto pos = t.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    t.replace(pos, from.size(), to);
    return resign_model_text(t);
  };
  EXPECT_NE(load_error(edited("\"rows\": 5", "\"rows\": 0")).find("SOM of 0 x 5 units"),
            std::string::npos);
  std::string no_hits = text;
  const auto h = no_hits.find("\"unit_hits\"");
  const auto open = no_hits.find('[', h), close = no_hits.find(']', h);
  std::string zeros = "[";
  for (int i = 0; i < 25; ++i) zeros += i ? ",0" : "0";
  no_hits.replace(open, close - open + 1, zeros + "]");
  EXPECT_NE(load_error(resign_model_text(no_hits)).find("no unit with training hits"),
            std::string::npos);
  // The re-signed original still loads: the checks above are what refused the others.
  EXPECT_EQ(deserialize_model(resign_model_text(text), "m.json").hash, m.hash);
}

TEST(TrainConfig, NonUtf8AndControlCharactersAreRefusedBeforeTheTomlParser) {
  for (const auto& [text, where] : std::vector<std::pair<std::string, std::string>>{
           {"[som]\nrows = 5\xff\n", "t.toml:2:9: invalid UTF-8"},
           {"[som]\nrows = \"\xed\xa0\x80\"\n", "t.toml:2:9: invalid UTF-8"},
           {"[som]\x01\n", "t.toml:1:6: control character"},
           {std::string("[som]\n") + '\0', "t.toml:2:1: control character"}}) {
    try {
      parse_train_config(text, "t.toml");
      ADD_FAILURE() << text;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(where, 0), 0u) << e.what();
    }
  }
  EXPECT_NO_THROW(check_plain_text("# caf\xc3\xa9 \xf0\x9f\x9a\x97\tok\r\n", "t.toml"));
}
