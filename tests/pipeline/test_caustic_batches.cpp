// Power where the techniques act (issue 46, item 2): a per-pixel agreement test that keeps the pixels
// seen through glass and the caustic, where light tracing of the caustics (render --set caustics=on) and
// guiding change the estimator -- and that rejects a bias confined there.
//
// Why batches: through glass and in a caustic the path tracer's samples are heavy-tailed, and a render's
// own variance layer (per-sample variance / spp) comes out low together with the mean in the renders
// that miss the rare large samples (test_guiding_unbiased.cpp masks those pixels for that reason).
// Here each estimator renders kBatches independent images (different seeds); per pixel the mean of
// the batch means is compared with a variance estimated from the spread of the batch means themselves,
//     t = (mean_a - mean_b) / sqrt(s2_a / B + s2_b / B),   s2 = sample variance over the B batches,
// which holds whatever the per-sample distribution as long as each batch mean is roughly normal (each
// is a mean of spp x pixel samples). t is Student-t with at least B - 1 degrees of freedom (the
// smaller of the two; Welch's approximation would give more), tested at every pixel, 4 x 4 block and
// the whole image, per channel, Bonferroni-corrected (family-wise false alarm below kAlpha).
//
// The scene (written below): a closed box lit by a large ceiling light through a thin glass pane
// (thindielectric) right under it, and a glass sphere on the floor. NEE is blocked by the pane, so all
// the direct light on the walls and floor is the caustic class (light -> pane -> diffuse surface), which
// --set caustics=on hands to the light tracer while the plain path tracer finds it by BSDF sampling (the
// light is large: often). The sphere's pixels (seen through glass) are tested like every other pixel.
// Unmutated, light-traced and path-traced images agree; the mutant caustic_bias (light-traced splats
// x 1.05, nothing else) must be rejected -- the mutant tier checks that it is.
// Measured (16 x 16 pixels, 256 spp per batch, 16 batches each, -t 1; ~25 s): unmutated, largest |t|
// pixel 3.5, block 2.2, image 0.7 against a threshold of 6.39; with caustic_bias, image |t| 10.7 (pixel
// 4.5, block 4.4). Power per pixel is not reached at this cost (the batch means' spread is ~10 % per
// pixel at 256 spp); a bias confined to a small caustic (the caustic box's, a few pixels) would need
// ~100 times the samples, so this test checks the class where it covers the image.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "formats/exr.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

constexpr int kBatches = 16;
constexpr double kAlpha = 0.01;
constexpr int kBlock = 4;

const char* kScene = R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="6"/></integrator>
  <shape type="cube">
    <boolean name="flipNormals" value="true"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.8" y="0.8"/><rotate x="1" angle="180"/><translate z="0.98"/></transform>
    <emitter type="area"><rgb name="radiance" value="2, 2, 2"/></emitter>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.9" y="0.9"/><translate z="0.9"/></transform>
    <bsdf type="thindielectric"><float name="intIOR" value="1.5"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="-0.6"/>
    <float name="radius" value="0.35"/>
    <bsdf type="dielectric"><float name="intIOR" value="1.5"/></bsdf>
  </shape>
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="toWorld"><lookAt origin="0.9, -0.9, 0.4" target="0, 0, -0.9" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
</scene>
)";

// Upper tail of Student's t with nu degrees of freedom: with x = sqrt(nu) tan(theta),
// P(T > t) = Gamma((nu+1)/2) / (sqrt(pi) Gamma(nu/2)) * integral_{atan(t/sqrt(nu))}^{pi/2} cos^(nu-1) theta,
// integrated by Simpson's rule (smooth integrand; 2000 intervals give ~1e-12 relative here).
double t_upper_tail(double t, double nu) {
    const double c = std::exp(std::lgamma((nu + 1) / 2) - std::lgamma(nu / 2)) / std::sqrt(M_PI);
    const double a = std::atan(t / std::sqrt(nu)), b = M_PI / 2;
    const int n = 2000;
    const double h = (b - a) / n;
    double s = 0;
    for (int i = 0; i <= n; ++i) {
        const double f = std::pow(std::cos(a + i * h), nu - 1);
        s += f * (i == 0 || i == n ? 1 : i % 2 ? 4 : 2);
    }
    return c * s * h / 3;
}

// Two-sided critical value: P(|T| > t) = p (bisection).
double t_critical(double p, double nu) {
    double lo = 0, hi = 1e4;
    for (int i = 0; i < 100; ++i) {
        const double mid = 0.5 * (lo + hi);
        (2 * t_upper_tail(mid, nu) > p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Per pixel and channel: the mean over batches and the variance of that mean (s2 / B).
struct BatchStats {
    int w = 0, h = 0;
    std::vector<double> mean[3], var[3];
};

BatchStats render_batches(const std::string& scene, const TempDir& dir, const std::string& label, const std::string& args,
                          int first_seed) {
    BatchStats s;
    std::vector<std::vector<float>> values[3];
    for (int b = 0; b < kBatches; ++b) {
        const std::string out = dir.file(label + std::to_string(b) + ".exr");
        const std::string cmd = tool("render") + " " + scene + " -q -t 1 --seed " + std::to_string(first_seed + b) + " " +
                                args + " -o " + out;
        const ToolResult r = run_command(cmd);
        EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
        if (r.status != 0) return {};
        const Image img = read_exr(out);
        s.w = img.width;
        s.h = img.height;
        for (int c = 0; c < 3; ++c) values[c].push_back(img.data[size_t(img.channel_index(std::string(1, "RGB"[c])))]);
    }
    const size_t n = size_t(s.w) * size_t(s.h);
    for (int c = 0; c < 3; ++c) {
        s.mean[c].assign(n, 0.0);
        s.var[c].assign(n, 0.0);
        for (size_t i = 0; i < n; ++i) {
            double m = 0, m2 = 0;
            for (int b = 0; b < kBatches; ++b) m += values[c][size_t(b)][i];
            m /= kBatches;
            for (int b = 0; b < kBatches; ++b) m2 += (values[c][size_t(b)][i] - m) * (values[c][size_t(b)][i] - m);
            s.mean[c][i] = m;
            s.var[c][i] = m2 / (kBatches - 1) / kBatches;
        }
    }
    return s;
}

struct Result {
    double worst[3] = {0, 0, 0};  // largest |t|: pixel, block, image
    int rejections = 0;
    std::string log;
};

Result compare(const BatchStats& a, const BatchStats& b, double t_crit) {
    Result r;
    auto test = [&](int level, double d, double v, const std::string& where) {
        if (v == 0 && d == 0) return;
        const double t = v > 0 ? d / std::sqrt(v) : INFINITY;
        r.worst[level] = std::max(r.worst[level], std::abs(t));
        if (std::abs(t) > t_crit && ++r.rejections <= 10) r.log += "  " + where + ": t = " + std::to_string(t) + "\n";
    };
    for (int c = 0; c < 3; ++c) {
        const std::string ch(1, "RGB"[c]);
        double all_d = 0, all_v = 0;
        for (int i = 0; i < a.w * a.h; ++i) {
            const double d = a.mean[c][size_t(i)] - b.mean[c][size_t(i)], v = a.var[c][size_t(i)] + b.var[c][size_t(i)];
            test(0, d, v, "pixel (" + std::to_string(i % a.w) + "," + std::to_string(i / a.w) + ") " + ch);
            all_d += d;
            all_v += v;
        }
        for (int by = 0; by < a.h; by += kBlock)
            for (int bx = 0; bx < a.w; bx += kBlock) {
                double d = 0, v = 0;
                for (int y = by; y < std::min(a.h, by + kBlock); ++y)
                    for (int x = bx; x < std::min(a.w, bx + kBlock); ++x) {
                        const size_t i = size_t(y * a.w + x);
                        d += a.mean[c][i] - b.mean[c][i];
                        v += a.var[c][i] + b.var[c][i];
                    }
                test(1, d, v, "block (" + std::to_string(bx) + "," + std::to_string(by) + ") " + ch);
            }
        test(2, all_d, all_v, "image " + ch);
    }
    return r;
}

TEST(CausticBatches, LightTracedCausticsAgreeWithThePathTracerPerPixelThroughGlass) {
    TempDir dir;
    const std::string scene = dir.file("scene.xml");
    std::ofstream(scene) << kScene;
    const BatchStats traced = render_batches(scene, dir, "traced", "--spp 256 " + cli::caustics("on"), 1000);
    const BatchStats plain = render_batches(scene, dir, "plain", "--spp 256", 2000);
    ASSERT_EQ(traced.w, 16);
    ASSERT_EQ(plain.w, traced.w);
    const int blocks = ((traced.w + kBlock - 1) / kBlock) * ((traced.h + kBlock - 1) / kBlock);
    const double tests = 3.0 * (traced.w * traced.h + blocks + 1);
    const double t_crit = t_critical(kAlpha / tests, kBatches - 1);
    const Result r = compare(traced, plain, t_crit);
    std::printf("%d batches each; %.0f t-tests (all pixels, glass and caustic included), threshold |t| > %.2f; "
                "largest |t|: pixel %.2f, block %.2f, image %.2f\n",
                kBatches, tests, t_crit, r.worst[0], r.worst[1], r.worst[2]);
    EXPECT_EQ(r.rejections, 0) << "the light-traced caustics disagree with the path tracer:\n" << r.log;
}

}  // namespace
