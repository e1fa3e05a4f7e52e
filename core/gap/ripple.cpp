// Encoder ripple: an eccentric or unevenly divided code wheel reads a speed that rises and falls
// once per revolution. Against the tyre's slope that is a force residual at the revolution rate
// (5e-4 of speed is 35 N on a 70 kN/unit-slip tyre), which no effect explains and which a
// diagnosis must not take for one. It is estimated per run and encoder from the baseline's
// residual and taken out of the slip.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/ripple_fit.hpp"

namespace brakefit::gap {

namespace {

/// A run must span this many revolutions of an encoder for its ripple's amplitude to be told
/// from the run's own trend; a shorter run (down to kMinPhaseRevolutions) takes the amplitude
/// found on the longer runs of the same encoder and estimates only its phase.
constexpr double kMinRevolutions = 1.5;
/// A run must hold this many samples for a ripple's phase to be placed on it at its encoder's
/// amplitude (a linear trend and two encoders' cos and sin leave it six degrees of freedom),
/// and kMinAmplitudeSamples for the amplitude to be read on it. A 50 Hz export's ground runs
/// hold 10-25 samples to the lock, and at 35 km/h a wheel's ripple leaves 35 N there. (Read
/// over 11-14 samples, a heavy vehicle's set took a reference amplitude of 1e-3 for 2.2e-4.)
constexpr std::size_t kMinRippleSamples = 12;
constexpr std::size_t kMinAmplitudeSamples = 20;
constexpr double kMinPhaseRevolutions = 0.5;
/// Shorter still (B's 60 bar/s roller stops turn the wheel 0.4-0.8 times), the phase alone is
/// scanned down to this. (Where a longer run's free phase fit disagrees with the encoder's
/// amplitude, the residual holds more than the ripple: scanned there, it took part of a 4 bar
/// brake threshold's signature.)
constexpr double kMinScanRevolutions = 0.25;
/// The residual the ripple explains at the revolution rate against the most it explains at half
/// and at twice that rate.
constexpr double kNarrowBand = 2.0;

}  // namespace

std::string remove_encoder_ripple(std::vector<Run>& runs, const std::vector<double>& params,
                                  const std::vector<Effect>& baseline, WhenNoRipple none) {
  const RippleModel model{params, baseline};
  struct Prepared {
    std::vector<double> residual;
    std::array<double, 2> revolutions{};
  };
  std::vector<Prepared> prep(runs.size());
  std::vector<RunColumns> columns;
  columns.reserve(runs.size());
  for (const Run& r : runs) columns.emplace_back(r, model);
  // Each estimate starts from the slip as conditioned, against the latest baseline (refitted on
  // the slip the previous estimate corrected): the estimates are not stacked, so a short run's
  // phase, placed once against a bent baseline, is placed again against a straighter one.
  // What each run holds on entry (restored when this estimate finds nothing).
  struct Kept {
    std::vector<double> slip, slip_sd, wheel_accel_mps2, ref_decel_mps2;
    double rest_noise_mps = NAN;
    std::size_t rest_slip_steps = 0;
  };
  std::vector<Kept> on_entry;
  on_entry.reserve(runs.size());
  for (Run& r : runs) {
    on_entry.push_back({r.slip, r.slip_sd, r.wheel_accel_mps2, r.ref_decel_mps2, r.rest_noise_mps,
                        r.rest_slip_steps});
    if (r.slip_as_conditioned.empty()) {
      r.slip_as_conditioned = r.slip;
      r.slip_sd_as_conditioned = r.slip_sd;
      r.wheel_accel_as_conditioned = r.wheel_accel_mps2;
      r.ref_decel_as_conditioned = r.ref_decel_mps2;
      r.ref_bias_as_conditioned = r.ref_bias_removed;
    } else {
      // As conditioned, with the bias levelled since (the levelling tracks what it took out).
      r.slip = r.slip_as_conditioned;
      for (double& s : r.slip) s -= r.ref_bias_removed - r.ref_bias_as_conditioned;
      r.slip_sd = r.slip_sd_as_conditioned;
      if (r.rest_probe) measure_rest_noise(r, {});
      // The wheel's acceleration and the reference's deceleration stay as the previous estimate
      // corrected them while the residual is taken: the regression's columns are the slip's
      // ripple, and a model that reads them (wheel inertia, load transfer) must not put their
      // ripple's derivative into the residual. They start again from as conditioned below.
    }
  }
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const Run& r = runs[k];
    const std::size_t n = r.t_s.size();
    if (n < kMinRippleSamples || r.wheel_angle_rad.size() != n || r.ref_angle_rad.size() != n)
      continue;
    const auto f = predict(r, params, baseline);
    Prepared& p = prep[k];
    // Residual = the model's answer to (1 - s) (eps_wheel - eps_ref) for speed ripples eps
    // (first order in eps; ripple_columns).
    for (std::size_t i = 0; i < n; ++i) p.residual.push_back(r.force_n[i] - f[i]);
    p.revolutions = {r.wheel_angle_rad.back() / (2 * M_PI), r.ref_angle_rad.back() / (2 * M_PI)};
  }
  // Pass 1: amplitude and phase on the runs spanning kMinRevolutions; an encoder's amplitude is
  // the median of its significant ones (one code wheel, one eccentricity).
  std::vector<RippleFit> fits(runs.size());
  int corrected = 0, uncorrected = 0;
  std::vector<bool> left_in(runs.size(), false);  // an encoder's ripple stays in the run
  std::array<std::vector<double>, 2> amps;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (prep[k].residual.size() < kMinAmplitudeSamples) continue;
    const std::array<bool, 2> use{
        prep[k].revolutions[0] >= kMinRevolutions,
        prep[k].revolutions[1] >= kMinRevolutions && !runs[k].ref_ripple_from_speed};
    if (!use[0] && !use[1]) continue;
    fits[k] = fit_ripple(columns[k], prep[k].residual, use, 2);
    // A ripple is narrow-band: at its encoder's revolution rate it must stand well above the
    // same fit at neighbouring rates (a residual left by an unmodelled effect is smooth and
    // broad-band, and must not be taken for one). Each encoder is checked with the other held at
    // its own rate: on the ground the fifth wheel turns about 1.7 times as fast as the wheel, so
    // half its rate is near the wheel's and would take the wheel's ripple for its own.
    // (Compared by the residual they explain beyond the trend and the other encoder: a fit at a
    // low rate over a short run is ill-conditioned, its coefficients large but its explained
    // variance not.)
    for (std::size_t e = 0; e < 2; ++e) {
      if (!fits[k].used[e]) continue;
      std::array<bool, 2> other = use;
      other[e] = false;
      const double without = fit_ripple(columns[k], prep[k].residual, other, 2).ssr;
      double neighbours = 0;
      for (const double scale : {0.5, 2.0}) {
        std::array<double, 2> scales{1.0, 1.0};
        scales[e] = scale;
        neighbours = std::max(
            neighbours, without - fit_ripple(columns[k], prep[k].residual, use, 2, scales).ssr);
      }
      const bool narrow = without - fits[k].ssr > kNarrowBand * neighbours;
      const double amp = std::hypot(fits[k].c[e], fits[k].s[e]);
      if (narrow && amp > 3 * fits[k].se[e] && amp < 0.01)
        amps[e].push_back(amp);
      else
        fits[k].used[e] = false;
    }
  }
  std::array<double, 2> amplitude{};
  std::string refuted_note;
  for (std::size_t e = 0; e < 2; ++e) {
    if (amps[e].empty()) continue;
    amplitude[e] = upper_median(amps[e]);
    // A ripple is the encoder's, in every sample it turns through: the rest before the brake,
    // where no effect acts, must show it too. An amplitude read on short runs' residual can be
    // an effect's bend the baseline leaves (0.0034 of a fifth wheel's speed on 50 Hz runs whose
    // rests hold under a tenth of it), which taken out, or left in their noise floor, would hide
    // the effect.
    if (const RestRippleCheck rest = rest_ripple_check(runs, e, amplitude[e]); rest.refutes()) {
      refuted_note += fmt::format(
          "; a {} ripple of {:.2g} read on the residual is not in the runs' rests ({} of {} that "
          "could see it hold less, {:.2g} in the median): the rests' amplitude is the encoder's",
          e == 0 ? "wheel" : "reference", amplitude[e], rest.refuted, rest.judged,
          rest.rest_amplitude);
      amplitude[e] = rest.rest_amplitude;
      for (RippleFit& f : fits) f.used[e] = false;
    }
  }
  // No run turns an encoder kMinRevolutions (a truck's wheel at 45-80 km/h turns once or twice
  // in a 0.3 s stop, and its 4e-4 ripple, 120 N on the tyre's slope, was left in the runs and out
  // of their floor): its amplitude is read on the rests, where the slip is flat and no effect
  // bends it, and pass 2 places its phase in each run.
  std::string rest_note;
  std::array<RestRipple, 2> rests;  // per encoder, where its amplitude is the rests'
  for (std::size_t e = 0; e < 2; ++e) {
    if (!amps[e].empty()) continue;
    if (e == 1 &&
        std::all_of(runs.begin(), runs.end(), [](const Run& r) { return r.ref_ripple_from_speed; }))
      continue;
    if (RestRipple r = rest_ripple(runs, e); r.amplitude > 0 && r.amplitude < 0.01) {
      amplitude[e] = r.amplitude;
      rests[e] = std::move(r);
      rest_note += fmt::format(
          "; no run turns the {} {} times, and its amplitude is read on the "
          "runs' rests before the brake",
          e == 0 ? "wheel" : "reference", kMinRevolutions);
    }
  }
  // Pass 2: shorter runs (and longer ones whose own estimate did not pass) take that amplitude
  // and their phase from a regression with a linear trend, when that regression's own amplitude
  // agrees with it (within a factor of 2); a run under half a revolution from a scan of the
  // phase alone at that amplitude. Where neither places it, the ripple stays in the run and its
  // slip noise carries it (the RMS of the smoothed wave at that amplitude, times 1 - s): the
  // floor is honest about what the smoother left of it.
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (prep[k].residual.empty()) continue;
    std::array<bool, 2> use{};
    for (std::size_t e = 0; e < 2; ++e) use[e] = !fits[k].used[e] && amplitude[e] > 0;
    use[1] = use[1] && !runs[k].ref_ripple_from_speed;  // read from its own speed
    if (!use[0] && !use[1]) continue;
    const RippleFit short_fit = fit_ripple(columns[k], prep[k].residual, use, 1);
    for (std::size_t e = 0; e < 2; ++e) {
      if (!use[e]) continue;
      // A run whose own rest holds the ripple read there takes its phase from it.
      if (const auto& cs = rests[e].phase.empty() ? std::nullopt : rests[e].phase[k]) {
        fits[k].used[e] = true;
        fits[k].c[e] = (*cs)[0];
        fits[k].s[e] = (*cs)[1];
        continue;
      }
      const double amp = std::hypot(short_fit.c[e], short_fit.s[e]);
      if (prep[k].revolutions[e] >= kMinPhaseRevolutions && amp > 0.5 * amplitude[e] &&
          amp < 2 * amplitude[e]) {
        fits[k].used[e] = true;
        fits[k].c[e] = short_fit.c[e] * amplitude[e] / amp;
        fits[k].s[e] = short_fit.s[e] * amplitude[e] / amp;
        continue;
      }
      // A free amplitude too uncertain to confirm the encoder's (within two of its standard
      // errors: a 50 Hz run of 25 samples over 13 revolutions read 1.2e-4 +- 1.4e-4 for 3.6e-4)
      // is no sign of more than the ripple: its phase is scanned as a short run's is.
      const bool uncertain = std::abs(amp - amplitude[e]) < 2 * short_fit.se[e];
      if (prep[k].revolutions[e] >= kMinScanRevolutions &&
          (prep[k].revolutions[e] < kMinPhaseRevolutions || uncertain))
        if (const auto cs = scan_phase(columns[k], prep[k].residual, e, amplitude[e])) {
          fits[k].used[e] = true;
          fits[k].c[e] = (*cs)[0];
          fits[k].s[e] = (*cs)[1];
          continue;
        }
      Run& r = runs[k];
      const Run::Wave wave = encoder_wave(r, e);
      for (std::size_t i = 0; i < r.slip_sd.size(); ++i)
        r.slip_sd[i] = std::hypot(r.slip_sd[i], amplitude[e] * wave_rms(wave, i) * (1 - r.slip[i]));
      left_in[k] = true;
      ++uncorrected;
    }
  }
  for (std::size_t k = 0; k < runs.size(); ++k) {
    Run& r = runs[k];
    r.wheel_accel_mps2 = r.wheel_accel_as_conditioned;
    r.ref_decel_mps2 = r.ref_decel_as_conditioned;
    if (fits[k].used[0] || fits[k].used[1]) {
      ++corrected;
      take_out_ripple(r, fits[k], ProbeAfter::AsMeasured);
    }
    // A ripple left in the run is in its rest too, where it would read as the speeds' noise
    // (its slip_sd carries it).
    if (left_in[k]) r.rest_noise_mps = NAN;
  }
  if (corrected == 0 && uncorrected == 0) {
    // Nothing found this time (an estimate's narrow-band test can fail against a refitted
    // baseline): the runs stay as the previous estimate left them, or as conditioned (the state
    // they are in here).
    if (none == WhenNoRipple::AsConditioned) return {};
    for (std::size_t k = 0; k < runs.size(); ++k) {
      runs[k].slip = std::move(on_entry[k].slip);
      runs[k].slip_sd = std::move(on_entry[k].slip_sd);
      runs[k].wheel_accel_mps2 = std::move(on_entry[k].wheel_accel_mps2);
      runs[k].ref_decel_mps2 = std::move(on_entry[k].ref_decel_mps2);
      runs[k].rest_noise_mps = on_entry[k].rest_noise_mps;
      runs[k].rest_slip_steps = on_entry[k].rest_slip_steps;
    }
    return {};
  }
  return fmt::format(
      "encoder ripple (once per revolution: an eccentric or unevenly divided code wheel) was "
      "found and taken out of the slip in {} of {} runs (amplitude of the speed: wheel {:.2g}, "
      "reference {:.2g}){}{}{}",
      corrected, runs.size(), amplitude[0], amplitude[1],
      uncorrected ? fmt::format("; where a run was too short to place its phase ({} encoder "
                                "runs), it stays in the run and in its noise floor",
                                uncorrected)
                  : std::string(),
      refuted_note, rest_note);
}

}  // namespace brakefit::gap
