// compare_images (libcommon/image_metrics.h): relMSE and its trimmed form on images with known errors,
// and the estimate of the reference's own share of relMSE from its variance layers: with a noisy
// reference whose per-pixel variance is known, relMSE minus that share must recover the test's error
// against the truth (what the benchmarks report as "reference noise removed").
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "libcommon/image_metrics.h"
#include "libcommon/rng.h"

namespace iris {
namespace {

constexpr int kW = 256, kH = 256;

// A smooth truth image, 0.1 .. 2.1 per channel.
std::vector<float> truth() {
    std::vector<float> t(size_t(kW) * kH * 3);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
            for (int c = 0; c < 3; ++c)
                t[3 * (size_t(y) * kW + x) + c] = 0.1f + 2.0f * float(x + y + 40 * c) / float(kW + kH + 80);
    return t;
}

// t plus normal noise of standard deviation `rel_sd` times t (Box-Muller).
std::vector<float> noisy(const std::vector<float>& t, float rel_sd, uint64_t seed) {
    Rng rng(seed, 3);
    std::vector<float> out(t.size());
    for (size_t i = 0; i < t.size(); ++i) {
        const float u1 = std::max(rng.next_float(), 1e-7f), u2 = rng.next_float();
        const float z = std::sqrt(-2.0f * std::log(u1)) * std::cos(6.2831853f * u2);
        out[i] = t[i] + rel_sd * t[i] * z;
    }
    return out;
}

// mean over pixels and channels of (rel_sd t)^2 / (t^2 + 0.01): the expected relMSE of noisy(t, rel_sd).
double expected_rel_mse(const std::vector<float>& t, float rel_sd) {
    double s = 0;
    for (float v : t) s += double(rel_sd * v) * double(rel_sd * v) / (double(v) * v + 0.01);
    return s / double(t.size());
}

TEST(ImageMetrics, RelMseOfKnownErrorsAndTheTrimmedForm) {
    const std::vector<float> t = truth();
    EXPECT_EQ(compare_images(t, t, kW, kH).rel_mse, 0.0);
    // Every value 10 % too high: relMSE = mean of 0.01 t^2 / (t^2 + 0.01).
    std::vector<float> a = t;
    for (float& v : a) v *= 1.1f;
    double want = 0;
    for (float v : t) want += 0.01 * double(v) * v / (double(v) * v + 0.01);
    want /= double(t.size());
    const ImageMetrics m = compare_images(a, t, kW, kH);
    EXPECT_NEAR(m.rel_mse, want, 1e-6 * want);
    EXPECT_EQ(m.rel_mse_reference_noise, -1.0);  // no variances given
    // One firefly pixel dominates relMSE; the trimmed form drops it.
    std::vector<float> f = t;
    f[3 * 1000] = 1e4f;
    const ImageMetrics mf = compare_images(f, t, kW, kH);
    EXPECT_GT(mf.rel_mse, 100.0);
    EXPECT_LT(mf.rel_mse_trimmed, 1e-12);
}

TEST(ImageMetrics, ReferenceNoiseShareRecoversTheErrorAgainstTheTruth) {
    const std::vector<float> t = truth();
    const float sd_ref = 0.05f, sd_test = 0.08f;
    const std::vector<float> ref = noisy(t, sd_ref, 1), test = noisy(t, sd_test, 2);
    std::vector<float> var(t.size());
    for (size_t i = 0; i < t.size(); ++i) var[i] = (sd_ref * t[i]) * (sd_ref * t[i]);

    const ImageMetrics m = compare_images(test, ref, kW, kH, {}, false, var);
    const double want_test = expected_rel_mse(t, sd_test), want_ref = expected_rel_mse(t, sd_ref);
    // Plain relMSE holds both images' noise; the share attributed to the reference is its own.
    EXPECT_NEAR(m.rel_mse, want_test + want_ref, 0.03 * (want_test + want_ref));
    EXPECT_NEAR(m.rel_mse_reference_noise, want_ref, 0.03 * want_ref);
    EXPECT_NEAR(m.rel_mse - m.rel_mse_reference_noise, want_test, 0.05 * want_test);
    // A test image equal to the truth: nothing is left once the reference's share is removed.
    const ImageMetrics exact = compare_images(t, ref, kW, kH, {}, false, var);
    EXPECT_NEAR(exact.rel_mse - exact.rel_mse_reference_noise, 0.0, 0.05 * want_ref);
}

}  // namespace
}  // namespace iris
