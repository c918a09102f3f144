// The fit at the noise (icp/fit.hpp). Oracles: closed forms of Gaussian residuals (RMS = σ, the
// median of |r| = 0.6745 σ), a tail of known size, and the two bounds of the expected residual.
#include "align3d/icp/fit.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "detail/random.hpp"

namespace align3d {
namespace {

std::vector<double> gaussian(std::size_t n, double sigma, Random& rng) {
  std::vector<double> r(n);
  for (double& x : r) x = sigma * rng.normal();
  return r;
}

// Residuals at the clouds' noise: expected σ₀, ratio 1.
TEST(Fit, ResidualsAtTheNoiseGiveARatioOfOne) {
  Random rng(1);
  const FitEvidence f = judge_fit(gaussian(200000, 0.1, rng), 0.1, 1.0);
  EXPECT_EQ(f.pairs, 200000u);
  EXPECT_NEAR(f.rms, 0.1, 0.001);
  EXPECT_NEAR(f.expected, 0.1, 0.002);  // σ₀, or the residuals' own scale just above it
  EXPECT_NEAR(f.ratio, 1.0, 0.02);
  EXPECT_LT(f.structured, 0.02);
}

// Two scans whose residuals are three times their own noise (structured error, fit.hpp): the
// expected residual follows the residuals' robust scale, the ratio stays about 1.
TEST(Fit, StructuredNoiseBelowHalfASpacingIsExpected) {
  Random rng(2);
  const FitEvidence f = judge_fit(gaussian(200000, 0.3, rng), 0.1, 1.0);
  EXPECT_NEAR(f.expected, 0.3, 0.005);
  EXPECT_NEAR(f.structured, std::sqrt(0.3 * 0.3 - 0.1 * 0.1), 0.005);
  EXPECT_NEAR(f.ratio, 1.0, 0.02);
}

// Residuals far above half a spacing (a pose off the surface) are not explained away: the expected
// residual stops at half a spacing and the ratio grows with them.
TEST(Fit, ResidualsBeyondHalfASpacingAreNot) {
  Random rng(3);
  const FitEvidence f = judge_fit(gaussian(100000, 2.0, rng), 0.1, 1.0);
  EXPECT_DOUBLE_EQ(f.expected, kStructuredSpacings * 1.0);
  EXPECT_NEAR(f.ratio, 2.0 / kStructuredSpacings, 0.05);
}

// A wrong local minimum: 80 % of the pairs at the noise, 20 % off the surface by 1.5 (a tail). The
// bulk's scale stays near σ₀ and the RMS is √(0.8 σ² + 0.2 · 1.5²) ≈ 0.68: a ratio far above
// kConfirmedFit's 1.75.
TEST(Fit, ATailOffTheSurfaceRaisesTheRatio) {
  Random rng(4);
  std::vector<double> r = gaussian(100000, 0.1, rng);
  for (std::size_t i = 0; i < r.size(); i += 5) r[i] = 1.5;
  const FitEvidence f = judge_fit(r, 0.1, 1.0);
  EXPECT_NEAR(f.rms, std::sqrt(0.8 * 0.01 + 0.2 * 2.25), 0.005);
  EXPECT_LT(f.expected, 0.15);
  EXPECT_GT(f.ratio, 4.0);
}

// Noise-free data: the expected residual is the floor, a twentieth of the spacing.
TEST(Fit, TheFloorStandsForNoiseFreeData) {
  const FitEvidence f = judge_fit({0.0, 0.0, 0.0}, 0.0, 2.0);
  EXPECT_DOUBLE_EQ(f.expected, kFitFloorSpacings * 2.0);
  EXPECT_EQ(f.ratio, 0.0);
  const FitEvidence none = judge_fit({}, 0.1, 1.0);
  EXPECT_EQ(none.pairs, 0u);
  EXPECT_EQ(none.ratio, 0.0);
  EXPECT_EQ(judge_fit({1.0}, 0.0, 0.0).ratio, std::numeric_limits<double>::infinity());
}

}  // namespace
}  // namespace align3d
