// Pixel reconstruction by filter importance sampling: each camera sample's film position is drawn
// from the reconstruction filter around the pixel centre, and the sample contributes to that pixel
// only, with weight f(x)/p(x) (~1). Compared with splatting (Mitsuba's way) this converges to the same
// filtered image, keeps pixels statistically independent (so per-pixel variance is meaningful and
// statistical tests are valid), needs no atomics, and makes the result independent of thread count.
#pragma once

#include <cstdint>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/scene.h"

namespace iris {

class FilterSampler {
public:
    explicit FilterSampler(const FilmSettings& film);
    // Offset from the pixel centre, in pixels, and the sample's weight f(x)/p(x).
    Vec2 sample(Vec2 u, float* weight) const;
    // Normalised 2D filter density at an offset from a pixel centre (pixels^-2; integrates to one), the
    // weight a light-traced splat gives that pixel: the same filter the camera samples integrate against.
    float density(Vec2 offset) const;
    // Half-width of the filter's support, pixels.
    float radius() const { return film_.filter == FilterType::Box ? 0.5f : film_.filter_radius; }

private:
    float eval1d(float x) const;
    FilmSettings film_;
    float inv_two_var_ = 0;  // 1 / (2 stddev^2), per pixel^2
    float floor_ = 0;        // the Gaussian's value at the radius, subtracted so the filter ends at zero
    std::vector<float> cdf_;  // piecewise-constant tabulation of the 1D filter over [-radius, radius]
    std::vector<float> pdf_;  // per pixel (1D density)
    // Where sample's search starts and ends for u in bucket g = floor(u kGuideBuckets): guide_[g] = the
    // number of CDF entries <= g / kGuideBuckets (std::upper_bound's answer there), so the answer for u
    // lies in [guide_[g], guide_[g + 1]] and a short scan finds exactly what the full search would.
    static constexpr int kGuideBuckets = 256;
    std::vector<uint16_t> guide_;
    float norm1d_ = 1;        // integral of eval1d over [-radius, radius]
};

// Accumulates weighted samples per pixel (double precision: long renders add millions of samples).
struct Film {
    int width = 0, height = 0;
    std::vector<double> sum_wl;    // 3 per pixel: sum of w * L
    std::vector<double> sum_wl2;   // 3 per pixel: sum of (w * L)^2, for the variance layer
    std::vector<double> sum_w;     // sum of weights
    std::vector<uint32_t> count;   // samples taken
    // Light-traced contributions (render's caustic light tracer), splatted through the filter: their sum
    // and sum of squares per pixel; the image adds sum / (light paths per sample x samples per pixel).
    // Allocated by enable_light only (48 bytes a pixel that a render without light tracing does not need).
    std::vector<double> light_sum, light_sum2;
    double light_paths_per_sample = 0;  // 0: no light tracing
    void enable_light(double paths_per_sample);

    Film(int w, int h);
    void add(int x, int y, RGB l, float weight) {
        size_t i = size_t(y) * width + x;
        for (int c = 0; c < 3; ++c) {
            double v = double(weight) * l[c];
            sum_wl[3 * i + c] += v;
            sum_wl2[3 * i + c] += v * v;
        }
        sum_w[i] += weight;
        count[i] += 1;
    }
    void add_light(size_t pixel, RGB v) {
        for (int c = 0; c < 3; ++c) {
            light_sum[3 * pixel + c] += v[c];
            light_sum2[3 * pixel + c] += double(v[c]) * v[c];
        }
    }
    RGB value(int x, int y) const;
    // Variance of the pixel estimate (not of one sample), per channel.
    RGB variance(int x, int y) const;
};

}  // namespace iris
