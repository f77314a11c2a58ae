#include "libcommon/film.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "libcommon/sampling.h"

namespace iris {

namespace {
constexpr int kFilterBins = 512;
}

FilterSampler::FilterSampler(const FilmSettings& film) : film_(film) {
    if (film_.filter == FilterType::Box) return;
    inv_two_var_ = 1.0f / (2 * film_.filter_stddev * film_.filter_stddev);
    floor_ = std::exp(-film_.filter_radius * film_.filter_radius * inv_two_var_);
    // Tabulate the 1D Gaussian; the 2D filter is separable, so x and y are sampled independently.
    const float r = film_.filter_radius, dx = 2 * r / kFilterBins;
    cdf_.assign(kFilterBins + 1, 0.0f);
    pdf_.assign(kFilterBins, 0.0f);
    double total = 0;
    std::vector<double> mass(kFilterBins);
    for (int i = 0; i < kFilterBins; ++i) {
        // Bin mass by Simpson's rule on the (smooth) filter.
        float a = -r + i * dx, b = a + dx;
        mass[i] = (eval1d(a) + 4 * eval1d(0.5f * (a + b)) + eval1d(b)) * dx / 6.0;
        total += mass[i];
    }
    double acc = 0;
    for (int i = 0; i < kFilterBins; ++i) {
        acc += mass[i];
        cdf_[i + 1] = float(acc / total);
        pdf_[i] = float(mass[i] / total / dx);
    }
    cdf_[kFilterBins] = 1.0f;
    norm1d_ = float(total);
    // (g / kGuideBuckets is exact in float: the bucket count is a power of two.)
    guide_.resize(kGuideBuckets + 1);
    for (int g = 0; g <= kGuideBuckets; ++g)
        guide_[g] = uint16_t(upper_bound_index(cdf_.data(), cdf_.size(), float(g) / kGuideBuckets));
}

float FilterSampler::density(Vec2 o) const {
    if (film_.filter == FilterType::Box) return std::abs(o.x) < 0.5f && std::abs(o.y) < 0.5f ? 1.0f : 0.0f;
    const float r = film_.filter_radius;
    if (!(std::abs(o.x) < r && std::abs(o.y) < r)) return 0.0f;
    return eval1d(o.x) * eval1d(o.y) / (norm1d_ * norm1d_);
}

float FilterSampler::eval1d(float x) const {
    // Mitsuba's truncated Gaussian: exp(-x^2/2s^2) - exp(-r^2/2s^2), clamped at zero.
    return std::max(0.0f, std::exp(-x * x * inv_two_var_) - floor_);
}

Vec2 FilterSampler::sample(Vec2 u, float* weight) const {
    if (film_.filter == FilterType::Box) {
        *weight = 1.0f;
        return {u.x - 0.5f, u.y - 0.5f};
    }
    const float r = film_.filter_radius, dx = 2 * r / kFilterBins;
    float w = 1.0f;
    float out[2];
    float uu[2] = {u.x, u.y};
    for (int k = 0; k < 2; ++k) {
        // upper_bound_index(cdf_, uu[k]) - 1 without the 10-step search: start at u's bucket's first
        // candidate and step while the CDF entry is <= u (a few entries: the buckets are uniform in u).
        const float uk = uu[k];
        const int g = uk >= 0 ? std::min(kGuideBuckets - 1, int(uk * kGuideBuckets)) : 0;
        int ub = guide_[g];
        const int ub_end = guide_[g + 1];
        while (ub < ub_end && cdf_[ub] <= uk) ++ub;
        int i = ub - 1;
        i = clamp(i, 0, kFilterBins - 1);
        float span = cdf_[i + 1] - cdf_[i];
        float t = span > 0 ? (uu[k] - cdf_[i]) / span : 0.5f;
        float x = -r + (i + clamp(t, 0.0f, 1.0f)) * dx;
        out[k] = x;
        w *= eval1d(x) / pdf_[i];
    }
    // Normalise so that the weight is 1 where the filter equals its tabulation: the per-pixel
    // estimate divides by the summed weights anyway, so only the ratio between samples matters.
    *weight = w;
    return {out[0], out[1]};
}

Film::Film(int w, int h)
    : width(w), height(h), sum_wl(size_t(w) * h * 3, 0.0), sum_wl2(size_t(w) * h * 3, 0.0),
      sum_w(size_t(w) * h, 0.0), count(size_t(w) * h, 0) {}

void Film::enable_light(double paths_per_sample) {
    light_paths_per_sample = paths_per_sample;
    light_sum.assign(size_t(width) * height * 3, 0.0);
    light_sum2.assign(size_t(width) * height * 3, 0.0);
}

RGB Film::value(int x, int y) const {
    size_t i = size_t(y) * width + x;
    if (sum_w[i] <= 0) return RGB(0.0f);
    double inv = 1.0 / sum_w[i];
    // Each pass of one sample per pixel also traces light_paths_per_sample light paths for the whole
    // image, so after count[i] samples the light tracer's estimate is its sum over that many paths.
    const double inv_light = light_paths_per_sample > 0 ? 1.0 / (light_paths_per_sample * count[i]) : 0.0;
    RGB v;
    for (int c = 0; c < 3; ++c)
        v[c] = float(sum_wl[3 * i + c] * inv + (inv_light > 0 ? light_sum[3 * i + c] * inv_light : 0.0));
    return v;
}

RGB Film::variance(int x, int y) const {
    size_t i = size_t(y) * width + x;
    double n = count[i];
    if (n < 2 || sum_w[i] <= 0) return RGB(0.0f);
    double mean_w = sum_w[i] / n;
    RGB r;
    for (int c = 0; c < 3; ++c) {
        double m = sum_wl[3 * i + c] / n, m2 = sum_wl2[3 * i + c] / n;
        double var_sample = std::max(0.0, (m2 - m * m) * n / (n - 1));
        // Saturate at the largest float: samples near 1e20 (legal radiances) have squares beyond float's
        // range, and an infinite variance would make the EXR writer refuse the whole image (found by
        // tests/stress/test_extreme_radiance.cpp). The sums themselves are double and do not overflow.
        double var = var_sample / n / (mean_w * mean_w);
        if (light_paths_per_sample > 0) {
            // The light tracer's own estimate: its paths are independent of the camera's.
            const double nl = light_paths_per_sample * n;
            const double lm = light_sum[3 * i + c] / nl, lm2 = light_sum2[3 * i + c] / nl;
            var += std::max(0.0, lm2 - lm * lm) / nl;
        }
        r[c] = float(std::min(var, double(std::numeric_limits<float>::max())));
    }
    return r;
}

}  // namespace iris
