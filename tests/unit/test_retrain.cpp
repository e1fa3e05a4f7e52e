// The shipped default model must be reproducible: retraining from the settings and seeds recorded
// in it gives the same map and network within tolerance.
#include <gtest/gtest.h>

#include "core/model_io.hpp"
#include "core/train.hpp"
#include "tests/unit/test_util.hpp"

using namespace brakefit;

TEST(ShippedModel, RetrainingFromItsRecordedSettingsReproducesIt) {
  const std::string path = brakefit::test::source_path("data/models/default.json");
  const Model shipped = deserialize_model(brakefit::test::read_text(path), path);
  Model again = train_model(shipped.config);
  EXPECT_LT((again.som.codebook() - shipped.som.codebook()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(again.unit_hits, shipped.unit_hits);
  ASSERT_EQ(again.mlp.size(), shipped.mlp.size());
  for (std::size_t k = 0; k < shipped.mlp.size(); ++k)
    EXPECT_LT((again.mlp[k].parameters() - shipped.mlp[k].parameters()).cwiseAbs().maxCoeff(), 1e-6)
        << "network " << k;
  EXPECT_NEAR(again.som_qe, shipped.som_qe, 1e-9);
  // Identification on a probe curve agrees.
  const Curve c = sample_curve({14, 1.6, 4000, 0.2, 0, 0}, even_slips(150, 0.27));
  for (Method m : {Method::Som, Method::Mlp}) {
    const auto a = run_method(m, &again, c).params, b = run_method(m, &shipped, c).params;
    EXPECT_NEAR(a.B, b.B, 1e-6 * b.B) << to_string(m);
    EXPECT_NEAR(a.D, b.D, 1e-6 * b.D) << to_string(m);
  }
}
