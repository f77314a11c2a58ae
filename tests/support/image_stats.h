// Image checks shared by the tests that render through the `render` binary: the per-channel mean and
// its standard error from the variance layer (pixels are independent under filter importance
// sampling), and the no-NaN/Inf contract.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "formats/exr.h"

namespace iris::test {

struct ImageStats {
    double mean[3] = {0, 0, 0};  // per channel R, G, B
    double se[3] = {0, 0, 0};    // standard error of each mean
};

// Mean and standard error per channel of an image rendered with --variance. Adds a test failure (naming
// `what`) for a missing channel, a non-finite or negative radiance, or a non-finite or negative variance.
inline ImageStats image_stats(const Image& img, const std::string& what = "") {
    ImageStats s;
    const char* names[3] = {"R", "G", "B"};
    const char* vnames[3] = {"variance.R", "variance.G", "variance.B"};
    const size_t n = size_t(img.width) * img.height;
    for (int c = 0; c < 3; ++c) {
        const int ci = img.channel_index(names[c]), vi = img.channel_index(vnames[c]);
        if (ci < 0 || vi < 0) {
            ADD_FAILURE() << what << ": missing channel " << names[c] << " or " << vnames[c];
            continue;
        }
        double sum = 0, var = 0;
        for (size_t i = 0; i < n; ++i) {
            const float v = img.data[ci][i], w = img.data[vi][i];
            EXPECT_TRUE(std::isfinite(v) && v >= 0 && std::isfinite(w) && w >= 0)
                << what << ": pixel " << i << " channel " << names[c] << " = " << v << ", variance " << w;
            sum += v;
            var += w;
        }
        s.mean[c] = sum / double(n);
        s.se[c] = std::sqrt(var) / double(n);
    }
    return s;
}

// The render discarded no NaN/Inf sample (EXR metadata iris:nonfinite_samples).
inline void expect_no_nonfinite(const Image& img, const std::string& what = "") {
    auto it = img.metadata.find("iris:nonfinite_samples");
    ASSERT_NE(it, img.metadata.end()) << what << ": no iris:nonfinite_samples metadata";
    EXPECT_EQ(it->second, "0") << what << ": NaN/Inf samples reached the film";
}

}  // namespace iris::test
