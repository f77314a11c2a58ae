#include "libcommon/image_metrics.h"

#include <algorithm>
#include <cmath>

#include "libcommon/spectrum.h"

namespace iris {

int to_srgb8(float linear) {
    float v = linear_to_srgb(std::max(0.0f, linear));
    return int(std::lround(clamp(v, 0.0f, 1.0f) * 255.0f));
}

namespace {
// Reference value in linear units.
inline float ref_linear(float v, bool srgb8) { return srgb8 ? srgb_to_linear(v) : v; }
}  // namespace

ImageMetrics compare_images(const std::vector<float>& test, const std::vector<float>& ref, int width, int height,
                            const std::vector<PixelRect>& masks, bool ref_is_srgb8,
                            const std::vector<float>& ref_variance) {
    ImageMetrics m;
    const bool with_variance = !ref_variance.empty();
    double ref_noise = 0;
    std::vector<double> per_pixel;
    per_pixel.reserve(size_t(width) * height);
    double sum_t[3] = {0, 0, 0}, sum_r[3] = {0, 0, 0}, sum_t8[3] = {0, 0, 0}, sum_r8[3] = {0, 0, 0};
    double rel = 0, mape = 0, mse = 0;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            bool masked = false;
            for (const PixelRect& r : masks) masked |= r.contains(x, y);
            if (masked) continue;
            size_t i = 3 * (size_t(y) * width + x);
            double px = 0;
            for (int c = 0; c < 3; ++c) {
                double a = test[i + c], r = ref_linear(ref[i + c], ref_is_srgb8);
                double e2 = (a - r) * (a - r);
                px += e2 / (r * r + 0.01);
                if (with_variance) ref_noise += double(ref_variance[i + c]) / (r * r + 0.01);
                mape += std::abs(a - r) / (std::abs(r) + 0.01);
                mse += e2;
                sum_t[c] += a;
                sum_r[c] += r;
                sum_t8[c] += to_srgb8(float(a));
                sum_r8[c] += ref_is_srgb8 ? std::lround(ref[i + c] * 255.0f) : to_srgb8(float(r));
            }
            rel += px;
            per_pixel.push_back(px);
        }
    uint64_t n = per_pixel.size();
    m.pixels = n;
    if (n == 0) return m;
    m.rel_mse = rel / (3.0 * n);
    if (with_variance) m.rel_mse_reference_noise = ref_noise / (3.0 * n);
    m.mape = mape / (3.0 * n);
    m.mse = mse / (3.0 * n);
    for (int c = 0; c < 3; ++c) {
        m.mean_test[c] = float(sum_t[c] / n);
        m.mean_ref[c] = float(sum_r[c] / n);
        m.mean_test_srgb8[c] = float(sum_t8[c] / n);
        m.mean_ref_srgb8[c] = float(sum_r8[c] / n);
    }
    // Drop the worst 0.1 % of pixels.
    size_t keep = n - n / 1000;
    std::nth_element(per_pixel.begin(), per_pixel.begin() + (keep ? keep - 1 : 0), per_pixel.end());
    double trimmed = 0;
    for (size_t i = 0; i < keep; ++i) trimmed += per_pixel[i];
    m.rel_mse_trimmed = keep ? trimmed / (3.0 * keep) : 0;
    return m;
}

std::vector<float> error_false_colour(const std::vector<float>& test, const std::vector<float>& ref, int width,
                                      int height, double scale, bool ref_is_srgb8) {
    std::vector<float> out(size_t(width) * height * 3);
    // A perceptually ordered ramp: black, blue, cyan, green, yellow, red.
    static const float ramp[6][3] = {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}};
    for (size_t p = 0; p < size_t(width) * height; ++p) {
        double e = 0;
        for (int c = 0; c < 3; ++c) {
            double a = test[3 * p + c], r = ref_linear(ref[3 * p + c], ref_is_srgb8);
            e += (a - r) * (a - r) / (r * r + 0.01);
        }
        double t = std::clamp(std::sqrt(e / 3.0 / scale), 0.0, 1.0) * 5.0;
        int k = std::min(4, int(t));
        double f = t - k;
        for (int c = 0; c < 3; ++c) out[3 * p + c] = float(ramp[k][c] * (1 - f) + ramp[k + 1][c] * f);
    }
    return out;
}

}  // namespace iris
