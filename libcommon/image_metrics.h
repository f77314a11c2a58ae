// Error metrics between a test image and a reference, on linear RGB float data (3 floats per pixel,
// row-major). Used by compare-images, the golden-file tests and the benchmarks.
#pragma once

#include <cstdint>
#include <vector>

#include "libcommon/color.h"

namespace iris {

struct ImageMetrics {
    double rel_mse = 0;           // mean over pixels and channels of (a - r)^2 / (r^2 + 0.01)
    double rel_mse_trimmed = 0;   // the same with the worst 0.1 % of pixels dropped (fireflies)
    double mape = 0;              // mean of |a - r| / (r + 0.01)
    double mse = 0;               // plain mean squared error
    RGB mean_test, mean_ref;      // per-channel means of the linear images
    RGB mean_test_srgb8, mean_ref_srgb8;  // per-channel means after sRGB encoding and 8-bit clipping (0..255)
    uint64_t pixels = 0;          // pixels compared (outside the mask)
    // With the reference's per-pixel variance (of its pixel means): mean over pixels and channels of
    // var_r / (r^2 + 0.01), the part of rel_mse the reference's own noise is expected to contribute
    // (test and reference independent: E[(a - r)^2] = E[(a - t)^2] + var_r for the truth t). rel_mse
    // minus this estimates the test's relMSE against the truth; -1 without variances.
    double rel_mse_reference_noise = -1;
};

// A rectangle of pixels to leave out (e.g. the Mitsuba banner in the seed references).
struct PixelRect {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // half-open [x0, x1) x [y0, y1)
    bool contains(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

// `test` and `ref` hold width*height*3 linear values. If a `ref_is_srgb8` image is given (a PNG), its
// values are sRGB-encoded 0..1 and are linearised for the relative metrics.
// `ref_variance`, if not empty, holds the reference's variance of each pixel mean (3 per pixel).
ImageMetrics compare_images(const std::vector<float>& test, const std::vector<float>& ref, int width, int height,
                            const std::vector<PixelRect>& masks = {}, bool ref_is_srgb8 = false,
                            const std::vector<float>& ref_variance = {});

// Per-pixel relative squared error (mean over channels) as a false-colour RGB image (3 floats per
// pixel, sRGB-encoded 0..1): black = no error, through blue, green, yellow to red = `scale` or more.
std::vector<float> error_false_colour(const std::vector<float>& test, const std::vector<float>& ref, int width,
                                      int height, double scale, bool ref_is_srgb8 = false);

// sRGB-encode and quantise to 8 bits as an image viewer would (clip to [0, 255], round).
int to_srgb8(float linear);

}  // namespace iris
