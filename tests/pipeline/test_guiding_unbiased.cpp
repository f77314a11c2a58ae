// Guided renders converge to the unguided image (DESIGN.md 4.9 and section 7), proven per pixel: on
// the tiny caustic scene, the whole pipeline (trace-photons, place-caches, fill-caches) builds an
// atlas, and each guided mode's render is compared with the unguided path tracer's (nee+bsdf) by
// z-tests of the difference against the variance layers both renders write:
//     z = (guided - unguided) / sqrt(var_guided + var_unguided)        (variances of the pixel means)
// at three scales -- every pixel, 4 x 4 pixel blocks and the whole image -- per channel and per mode.
// Pixels are independent (box filter, each sample lands in one pixel; the renders use different
// seeds), so a block's difference is the sum of its pixels' and its variance the sum of theirs. All
// tests are Bonferroni-corrected together: the family-wise false-alarm rate is below kAlpha.
//
// Why three scales and these sample counts: a guided estimator can be heavy-tailed where its cache
// says little about the integrand (bsdf+cache has no NEE: direct light comes from rare hits of the
// small light). Then a pixel's mean *and* its variance estimate come out low together in the runs that
// miss the rare large samples, and the per-pixel z-test, which assumes a normal mean, rejects a correct
// image. Measured on this scene at 1024 spp: bsdf+cache's largest pixel |z| was 4.6-6.1 in six runs
// (above the threshold of ~4.9 in three), the NEE modes' at most 3.8. At 4096 spp bsdf+cache's largest
// |z| in six runs was 4.3. So bsdf+cache renders 4096 spp, the others 1024 (about 20 s in all on two
// cores). nee+bsdf+cache runs twice: as the fixed mode renders it (the first vertex guided) and as the
// deep setting the pilot may choose (every vertex guided, Russian roulette below throughput 0.1). The per-pixel test cannot see a 5 % bias in bsdf+cache (its pixels are too noisy: |z| <= 3.9
// for the scaled image); the block and image tests can. And the test proves its power: every mode's
// guided image scaled by 1.05 must be rejected (measured in six runs: per-pixel |z| 6.5-8.8 for the NEE
// modes, image-mean |z| 13-18 for all three modes).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "formats/exr.h"
#include "formats/scene_xml.h"
#include "libcommon/camera.h"
#include "libcommon/scene.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

constexpr double kAlpha = 0.01;  // family-wise significance over all tests below
constexpr int kBlock = 4;        // block size in pixels for the intermediate scale

struct Mode {
    const char* name;
    int spp;
    bool direct_atlas;  // bsdf+cache has no NEE: its caches include the direct light (fill-caches --set direct-photons=on)
    const char* extra = "";
};
// The last: the deep setting the pilot may choose (every vertex guided, less roulette).
// The last two: hybrid caches (render --set learn=on), the maps refit from photons and path samples after
// 1, 2, 4, ... 512 spp, the fixed and the deep setting.
const Mode kModes[] = {{"nee+cache", 1024, false},
                       {"bsdf+cache", 4096, true},
                       {"nee+bsdf+cache", 1024, false},
                       {"nee+bsdf+cache", 1024, false, "--set guide-vertices=0 --set rr-threshold=0.1"},
                       {"nee+bsdf+cache", 1024, false, "--set learn=on"},
                       {"nee+bsdf+cache", 1024, false, "--set guide-vertices=0 --set rr-threshold=0.1 --set learn=on"}};
constexpr int kModeCount = 6;

// Two-sided normal critical value for tail probability p: z with erfc(z / sqrt 2) = p (bisection).
double normal_critical(double p) {
    double lo = 0, hi = 40;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Colour channels and variance layers of an image, as double arrays.
struct Layers {
    int w = 0, h = 0;
    std::vector<double> value[3], var[3];
};
Layers layers(const Image& img) {
    Layers l;
    l.w = img.width;
    l.h = img.height;
    const char* names[3] = {"R", "G", "B"};
    const char* vnames[3] = {"variance.R", "variance.G", "variance.B"};
    for (int c = 0; c < 3; ++c) {
        const int ci = img.channel_index(names[c]), vi = img.channel_index(vnames[c]);
        EXPECT_GE(ci, 0);
        EXPECT_GE(vi, 0);
        if (ci < 0 || vi < 0) continue;
        l.value[c].assign(img.data[ci].begin(), img.data[ci].end());
        l.var[c].assign(img.data[vi].begin(), img.data[vi].end());
    }
    return l;
}

struct Verdict {
    double worst_z[3] = {0, 0, 0};  // largest |z| per scale: pixel, block, image
    std::string worst_where[3];
    int rejections = 0;
    std::string log;  // the first rejections, for the failure message
};

// All z-tests of `guided` (its values multiplied by `scale`) against `unguided`, leaving out the pixels
// `skip` marks (if given).
Verdict compare(const Layers& guided, const Layers& unguided, double scale, double z_crit,
                const std::vector<char>* skip = nullptr) {
    Verdict v;
    const int w = unguided.w, h = unguided.h;
    auto test = [&](int level, double diff, double var, const std::string& where) {
        // A zero variance on both sides (no sample ever varied) must mean equal values.
        const double z = var > 0 ? diff / std::sqrt(var) : (diff == 0 ? 0.0 : INFINITY);
        if (std::abs(z) > v.worst_z[level]) {
            v.worst_z[level] = std::abs(z);
            v.worst_where[level] = where;
        }
        if (std::abs(z) > z_crit && ++v.rejections <= 10) {
            char buf[200];
            std::snprintf(buf, sizeof buf, "  %s: difference %.4g, z = %.2f\n", where.c_str(), diff, z);
            v.log += buf;
        }
    };
    const char* ch = "RGB";
    for (int c = 0; c < 3; ++c) {
        auto skipped = [&](int i) { return skip && (*skip)[size_t(i)]; };
        auto diff_at = [&](int i) {
            return skipped(i) ? 0.0 : scale * guided.value[c][size_t(i)] - unguided.value[c][size_t(i)];
        };
        auto var_at = [&](int i) {
            return skipped(i) ? 0.0 : scale * scale * guided.var[c][size_t(i)] + unguided.var[c][size_t(i)];
        };
        double all_d = 0, all_v = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const int i = y * w + x;
                if (skipped(i)) continue;
                test(0, diff_at(i), var_at(i),
                     "pixel (" + std::to_string(x) + "," + std::to_string(y) + ") " + std::string(1, ch[c]));
                all_d += diff_at(i);
                all_v += var_at(i);
            }
        for (int by = 0; by < h; by += kBlock)
            for (int bx = 0; bx < w; bx += kBlock) {
                double d = 0, s2 = 0;
                for (int y = by; y < std::min(h, by + kBlock); ++y)
                    for (int x = bx; x < std::min(w, bx + kBlock); ++x) {
                        d += diff_at(y * w + x);
                        s2 += var_at(y * w + x);
                    }
                if (s2 == 0 && d == 0) continue;  // every pixel skipped
                test(1, d, s2, "block at (" + std::to_string(bx) + "," + std::to_string(by) + ") " + std::string(1, ch[c]));
            }
        test(2, all_d, all_v, std::string("image mean ") + ch[c]);
    }
    return v;
}

// The preprocessing pipeline through the tools' command lines, as a user runs it: photons, caches, and
// two atlases (without and with the photons that come straight from the lights).
bool build_atlases(const std::string& scene, const TempDir& dir) {
    auto run = [](const std::string& cmd) {
        ToolResult r = run_command(cmd);
        EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
        return r.status == 0;
    };
    const std::string fill = tool("fill-caches") + " " + dir.file("caches.h5") + " -q --photon-map " +
                             dir.file("photons.h5") + " --set gather-count=400";
    return run(tool("trace-photons") + " " + scene + " -q --set photon-paths=50000 --seed 1 -o " + dir.file("photons.h5")) &&
           run(tool("place-caches") + " " + scene + " -q --photon-map " + dir.file("photons.h5") + " --set cache-count=400 -o " +
               dir.file("caches.h5")) &&
           run(fill + " -o " + dir.file("atlas.h5")) && run(fill + " --set direct-photons=on -o " + dir.file("atlas_direct.h5"));
}

// Renders `scene` with --variance into DIR/NAME.exr and returns its layers.
Layers render(const std::string& scene, const TempDir& dir, const std::string& name, const std::string& args) {
    const std::string out = dir.file(name + ".exr"),
                      cmd = tool("render") + " " + scene + " -q --variance -o " + out + " " + args;
    ToolResult r = run_command(cmd);
    EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
    return r.status == 0 ? layers(read_exr(out)) : Layers{};
}

double test_count(const Layers& l, int modes) {
    const int blocks = ((l.w + kBlock - 1) / kBlock) * ((l.h + kBlock - 1) / kBlock);
    return double(modes) * 3 * (l.w * l.h + blocks + 1);
}

TEST(GuidingUnbiased, GuidedModesAgreeWithUnguidedPerPixel) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    const Layers unguided = render(scene, dir, "unguided", "--spp 1024 --seed 1");
    ASSERT_EQ(unguided.w, 32);
    ASSERT_EQ(unguided.h, 32);
    const double tests = test_count(unguided, kModeCount);
    const double z_crit = normal_critical(kAlpha / tests);  // ~4.9
    std::printf("%.0f z-tests, Bonferroni threshold |z| > %.3f\n", tests, z_crit);

    int seed = 2;
    for (const Mode& m : kModes) {
        const std::string extra = m.extra;
        const std::string label = std::string(m.name) + (extra.find("guide-vertices=") != std::string::npos ? " (deep)" : "") +
                                  (extra.find("--set learn=on") != std::string::npos ? " (hybrid)" : "");
        SCOPED_TRACE(label + " " + m.extra);
        const Layers guided = render(scene, dir, "mode" + std::to_string(seed),
                                     std::string("--set pilot=off --set mode=") + m.name + " --spp " + std::to_string(m.spp) +
                                         " --seed " + std::to_string(seed) + " --atlas " +
                                         dir.file(m.direct_atlas ? "atlas_direct.h5" : "atlas.h5") + " " + m.extra);
        ++seed;
        ASSERT_EQ(guided.w, unguided.w);
        const Verdict v = compare(guided, unguided, 1.0, z_crit);
        std::printf("%-22s largest |z|: pixel %.2f (%s), block %.2f, image %.2f\n", label.c_str(), v.worst_z[0],
                    v.worst_where[0].c_str(), v.worst_z[1], v.worst_z[2]);
        EXPECT_EQ(v.rejections, 0) << label << " disagrees with the unguided render:\n" << v.log;
        // Power: the same test must reject an image 5 % too bright.
        const Verdict biased = compare(guided, unguided, 1.05, z_crit);
        std::printf("%-22s x 1.05:      pixel %.2f, block %.2f, image %.2f\n", label.c_str(), biased.worst_z[0],
                    biased.worst_z[1], biased.worst_z[2]);
        EXPECT_GT(biased.rejections, 0) << "the test cannot tell a 5 % bias in " << label;
    }
}

// The modes with NEE (nee+cache, nee+bsdf+cache; bsdf+cache needs far more samples, see above) against
// the unguided render per pixel on `scene_file` (`spp` per guided render, `unguided_spp` for the
// unguided one), with `flags` added to the guided renders.
void expect_nee_modes_agree(const std::string& scene_file, const std::string& flags, int spp = 512, int unguided_spp = 512) {
    TempDir dir;
    const std::string scene = data_file(scene_file);
    ASSERT_TRUE(build_atlases(scene, dir));
    const std::string spp_flag = " --spp " + std::to_string(spp);
    const Layers unguided = render(scene, dir, "unguided", " --spp " + std::to_string(unguided_spp) + " --seed 1");
    ASSERT_EQ(unguided.w, 32);
    const double z_crit = normal_critical(kAlpha / test_count(unguided, 2));
    int seed = 2;
    for (const char* mode : {"nee+cache", "nee+bsdf+cache"}) {
        SCOPED_TRACE(mode);
        const Layers guided = render(scene, dir, mode,
                                     std::string("--set pilot=off --set mode=") + mode + " " + flags + spp_flag + " --seed " +
                                         std::to_string(seed++) + " --atlas " + dir.file("atlas.h5"));
        ASSERT_EQ(guided.w, unguided.w);
        const Verdict v = compare(guided, unguided, 1.0, z_crit);
        std::printf("%-15s largest |z|: pixel %.2f (%s), block %.2f, image %.2f\n", mode, v.worst_z[0],
                    v.worst_where[0].c_str(), v.worst_z[1], v.worst_z[2]);
        EXPECT_EQ(v.rejections, 0) << mode << " disagrees with the unguided render on " << scene_file << ":\n" << v.log;
    }
}

// The same comparison on a scene with layered BSDFs, a coat beside a diffuse lobe (smooth plastic:
// a Dirac coat; rough plastic and Ward: glossy ones). At a guided vertex the cache replaces only the
// diffuse lobe; the coat keeps the BSDF's own sampling probability, and the mixture density
// p_bsdf + (1 - alpha)(g p_cache - q) must be the one the samples come from (DESIGN.md 4.3, 4.4).
// The tiles cover about a quarter of the image.
TEST(GuidingUnbiased, ModesKeepTheCoatOfLayeredBsdfs) { expect_nee_modes_agree("guiding/layered_tiles_box.xml", ""); }

// The same on tiles of phong, a mixturebsdf (a silver mirror beside a white diffuse, weights 1, 1: the
// mirror is a Dirac lobe the cache leaves alone, the diffuse part is replaced) and a blendbsdf with a
// textured weight (a diffuse and a rough conductor, each guidable in proportion to its weight):
// tests/data/guiding/mixture_tiles_box.xml. Every vertex guided, and the photons and caches see the
// mixtures too (about 14 s on two cores). Checked to fail: the mixture's guidable share counting its mirror
// part as replaceable (pixel |z| 15-17), and bsdf_sample's lobe choice ignoring the parts' shares, so
// that uc >= 1 - share can pick the mirror (pixel |z| 9-10, block 13-22).
TEST(GuidingUnbiased, PhongAndMixturesKeepTheImage) {
    expect_nee_modes_agree("guiding/mixture_tiles_box.xml", "--set guide-vertices=0 --set rr-threshold=0.1");
}
// The same with caustic connections and the caustic light tracer, on the scene without its glass sphere
// (tests/data/guiding/mixture_mirror_box.xml; through the glass, such per-pixel tests are heavy-tailed:
// with the sphere, the largest pixel |z| wandered between pixels and did not grow with 4x the samples):
// light the mixture's mirror part reflects onto the walls is a caustic both techniques make (the mirror
// part continues light paths, the diffuse part ends them and receives connections).
TEST(GuidingUnbiased, MixtureMirrorCausticsKeepTheImage) {
    expect_nee_modes_agree("guiding/mixture_mirror_box.xml",
                           "--set connect=on --set caustics=on --set guide-vertices=0 --set rr-threshold=0.1");
}

// The same on glossy metal tiles (a rough conductor, a Ward without a diffuse part), where the cache
// technique samples the map's product with the glossy lobe (render --set product=on, Guide::product): its
// density p = d_k e_K / Z must be the one its samples come from, with MIS against NEE and the BSDF, and
// in nee+cache (no BSDF technique) its support must cover the lobe's. Every vertex guided, so that the
// product also serves the tiles' reflections of each other and of the walls. Checked to fail: a product
// density 10 % too large (Guide::product_pdf scaled) is rejected in both modes (block |z| 6.4-6.8).
TEST(GuidingUnbiased, ProductWithGlossyLobesKeepsTheImage) {
    expect_nee_modes_agree("guiding/glossy_tiles_box.xml", "--set product=on --set guide-vertices=0");
}

// Caustic connections (render --set connect=on, tools/render/connections.h): every non-Dirac vertex joins a
// light vertex behind a specular chain, weighed by the power heuristic against the path tracer's own
// emitter hits after such chains. The two weights must sum to one for every path, with the densities of
// the guided mixture at both ends of the connecting edge, with the caustics seen directly light-traced
// (the pools are then the light tracer's paths) and without (pools of their own). On a box lit through a
// glass slab under its light (tests/data/guiding/glass_lamp_box.xml), where such paths are most of the
// image. 1024 guided and 4096 unguided samples: the unguided render's rare caustic paths are the heavier
// tail. Checked to fail: the path tracer's weight left at 1 (those paths counted twice) is rejected
// in every run (block |z| 10.7-15.3, image |z| 62-91).
TEST(GuidingUnbiased, CausticConnectionsKeepTheImage) {
    expect_nee_modes_agree("guiding/glass_lamp_box.xml", "--set connect=on --set caustics=on --set guide-vertices=0 --set rr-threshold=0.1",
                           1024, 4096);
    expect_nee_modes_agree("guiding/glass_lamp_box.xml", "--set connect=on", 1024, 4096);
}

// The same through a thin pane (`thindielectric`) under the light instead of the slab
// (tests/data/guiding/thin_pane_box.xml): the Dirac chain is one vertex that passes light straight on,
// and photons, caches, the light tracer, its pools and the connections' weights all go through it.
TEST(GuidingUnbiased, ThinPaneUnderTheLightKeepsTheImage) {
    expect_nee_modes_agree("guiding/thin_pane_box.xml",
                           "--set connect=on --set caustics=on --set guide-vertices=0 --set rr-threshold=0.1", 1024, 4096);
}

// Light tracing of the caustics seen directly (render --set caustics=on, tools/render/caustics.h) splits path
// space with the path tracer: the path tracer drops the caustic class and the light tracer adds it, so
// the image must still be the plain path tracer's, per pixel -- unguided and with the deep guided
// setting (every vertex guided; the guiding pilot weighs the camera paths that remain).
// On the caustic box the class is about a tenth of the image's brightness (measured: the light tracer's
// mean over all pixels 0.0166 against the image's mean luminance 0.170), nearly all of it in the caustic
// beside the sphere's foot: a light tracer that lost or doubled its part, or got its
// camera factor wrong, moves those pixels by far more than the 5 % scaling that the test must reject
// (its power check). Measured: a light tracer 10 % too bright is rejected in both runs (block |z| 5.6-6.0,
// image |z| 5.2-5.7; the threshold is ~4.8).
//
// The test leaves out the pixels where the camera sees the glass sphere (any of 8 x 8 rays per pixel
// hits a surface with a Dirac lobe): there both renders run the same estimator (class C starts at a
// directly seen non-Dirac vertex), of the caustic on the floor seen through the glass, whose rare
// large samples make the variance layers unreliable (measured: |z| up to 5.6 there at 16384 spp,
// both renders too low or too high together with their variances).
std::vector<char> seen_through_glass(const std::string& scene_path, int w, int h) {
    Scene scene = load_scene(scene_path, SceneLoadOptions{});
    Camera camera = scene.camera;
    camera_prepare(camera, w, h);
    std::vector<char> mask(size_t(w) * size_t(h), 0);
    constexpr int kSub = 8;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < kSub * kSub && !mask[size_t(y * w + x)]; ++k) {
                SurfaceHit hit;
                const Ray ray = camera_ray(camera, x + (k % kSub + 0.5f) / kSub, y + (k / kSub + 0.5f) / kSub, w, h);
                if (scene.intersect(ray, &hit) && bsdf_has_delta_lobe(scene.bsdfs[hit.bsdf])) mask[size_t(y * w + x)] = 1;
            }
    return mask;
}

TEST(CausticLightTracing, AgreesWithThePathTracerPerPixel) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    const Layers unguided = render(scene, dir, "unguided", "--spp 4096 --seed 1");
    ASSERT_EQ(unguided.w, 32);
    const std::vector<char> skip = seen_through_glass(scene, unguided.w, unguided.h);
    int skipped = 0;
    for (char c : skip) skipped += c;
    std::printf("%d of %d pixels see the glass sphere (left out)\n", skipped, unguided.w * unguided.h);
    ASSERT_GT(skipped, 0);
    ASSERT_LT(skipped, unguided.w * unguided.h / 2);
    const double z_crit = normal_critical(kAlpha / test_count(unguided, 2));
    const std::pair<const char*, std::string> runs[] = {
        {"light-traced, unguided", "--set caustics=on --spp 1024 --seed 2"},
        {"light-traced, every vertex guided", "--set caustics=on --spp 1024 --seed 3 --set mode=nee+bsdf+cache --set pilot=off --atlas " +
                                                  dir.file("atlas.h5") + " --set guide-vertices=0 --set rr-threshold=0.1"}};
    int i = 0;
    for (const auto& [label, args] : runs) {
        SCOPED_TRACE(label);
        const Layers traced = render(scene, dir, "traced" + std::to_string(i++), args);
        ASSERT_EQ(traced.w, unguided.w);
        const Verdict v = compare(traced, unguided, 1.0, z_crit, &skip);
        std::printf("%-34s largest |z|: pixel %.2f (%s), block %.2f, image %.2f\n", label, v.worst_z[0],
                    v.worst_where[0].c_str(), v.worst_z[1], v.worst_z[2]);
        EXPECT_EQ(v.rejections, 0) << label << " disagrees with the path tracer:\n" << v.log;
        const Verdict biased = compare(traced, unguided, 1.05, z_crit, &skip);
        EXPECT_GT(biased.rejections, 0) << "the test cannot tell a 5 % bias in " << label;
    }
}

// Renders `scene` unguided at `spp` and with each of `runs` (label, render flags), and checks that every
// run agrees with the unguided render per pixel, per block and over the image, and that the test would
// reject a 5 % bias. The scene's atlas is built into `dir` first (atlas.h5, for flags that name it).
void expect_agrees_per_pixel(const std::string& scene, const TempDir& dir, int spp,
                             const std::vector<std::pair<std::string, std::string>>& runs) {
    const std::string n = " --spp " + std::to_string(spp);
    const Layers unguided = render(scene, dir, "unguided", n + " --seed 1");
    const double z_crit = normal_critical(kAlpha / test_count(unguided, 2));
    int i = 0;
    for (const auto& [label, args] : runs) {
        SCOPED_TRACE(label);
        const Layers other = render(scene, dir, "run" + std::to_string(i), n + " --seed " + std::to_string(i + 2) + " " + args);
        ++i;
        ASSERT_EQ(other.w, unguided.w);
        const Verdict v = compare(other, unguided, 1.0, z_crit);
        std::printf("%-24s largest |z|: pixel %.2f (%s), block %.2f, image %.2f\n", label.c_str(), v.worst_z[0],
                    v.worst_where[0].c_str(), v.worst_z[1], v.worst_z[2]);
        EXPECT_EQ(v.rejections, 0) << label << " disagrees with the unguided render:\n" << v.log;
        EXPECT_GT(compare(other, unguided, 1.05, z_crit).rejections, 0) << "the test cannot tell a 5 % bias";
    }
}

// An envmap scene (glass sphere on a floor, lit only by the map): guided rendering, and the light
// tracer's environment caustics, agree with the unguided path tracer per pixel.
TEST(GuidingUnbiased, EnvmapSceneAgreesPerPixel) {
    TempDir dir;
    const std::string scene = data_file("guiding/env_glass.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    expect_agrees_per_pixel(scene, dir, 512,
                            {{"guided nee+bsdf+cache", "--set mode=nee+bsdf+cache --set pilot=off --atlas " + dir.file("atlas.h5")},
                             {"light-traced caustics", "--set caustics=on"}});
}

// The same on a sunsky (tests/data/guiding/sunsky_glass.xml: sky and a sun disk in one map, the sun's
// texels some 10^4 times brighter than the sky's): photons, caches, guided rendering, the light tracer's
// sun caustic under the glass sphere and caustic connections all take the peaked map as any envmap.
// The camera looks at the sphere's shadow, where the caustic lies. Measured: largest pixel |z| 2.6, 4.2
// and 2.4 for the three runs; checked to fail: a light tracer whose environment flux is 20 % too large
// (emission.cpp) is rejected (block |z| 4.1, image |z| 5.7).
TEST(GuidingUnbiased, SunskySceneAgreesPerPixel) {
    TempDir dir;
    const std::string scene = data_file("guiding/sunsky_glass.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    expect_agrees_per_pixel(scene, dir, 512,
                            {{"guided nee+bsdf+cache", "--set mode=nee+bsdf+cache --set pilot=off --atlas " + dir.file("atlas.h5")},
                             {"light-traced caustics", "--set caustics=on"},
                             {"caustic connections", "--set connect=on"}});
}

// Caustic connections to vertices lit by an envmap through a specular chain: a greenhouse whose glass
// roof (a thin pane) is the only way in for the map's light (tests/data/guiding/env_greenhouse.xml), so
// that most of the image is walls seen from walls lit through the roof. Both strategies' weights use the
// map's density of the direction each chain leaves to (light_emit_density); the guided modes, every
// vertex guided, agree with the plain path tracer per pixel (1024 and 4096 samples, as above). The
// roof's caustics are not light-traced here (the pools are the connections' own): in the image's
// corners, floor right under the camera, the light tracer's splats are rare and large, and at 1024
// samples one seed's pixel came out a third low with a variance layer that did not show it (|z| 6.6;
// 4 x 8192 samples of the same setting agree within |z| 3.3 over every pixel). Checked to fail: the
// path tracer's weight of sky paths after a chain left at 1 (counted twice) is rejected (block |z|
// 20-30, image |z| 86-190). A density of the opposite direction on one side is not: this sky is too
// even for the weights' error to show.
TEST(GuidingUnbiased, EnvmapConnectionsThroughAGlassRoof) {
    expect_nee_modes_agree("guiding/env_greenhouse.xml", "--set connect=on --set guide-vertices=0 --set rr-threshold=0.1", 1024, 4096);
}

// A textured scene (tests/data/guiding/textured_box.xml: bitmap and checkerboard reflectances, a
// textured roughness, a scaled texture): photons, caches and guided rendering all read the BSDF at the
// hit's uv, and guided rendering (first vertex, and every vertex) agrees with the unguided path tracer
// per pixel.
TEST(GuidingUnbiased, TexturedSceneAgreesPerPixel) {
    TempDir dir;
    const std::string scene = data_file("guiding/textured_box.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    const std::string atlas = " --atlas " + dir.file("atlas.h5");
    expect_agrees_per_pixel(scene, dir, 256,
                            {{"guided nee+bsdf+cache", "--set mode=nee+bsdf+cache --set pilot=off" + atlas},
                             {"every vertex guided", "--set mode=nee+bsdf+cache --set pilot=off --set guide-vertices=0 --set rr-threshold=0.1" + atlas}});
}

// The pilot (render --atlas) weighs unguided sampling against guiding the first vertex and, unless the user
// set guide-vertices, rr-depth or rr-threshold, guiding every vertex with Russian roulette only below
// throughput 0.1 (the default threshold is 0.3; the caustic box's rrDepth is the default, 5); the image
// records every candidate the pilot measured and the setting it rendered with, and renders what it chose.
TEST(GuidingAuto, WeighsEveryVertexOnlyWhereTheUserLeftTheChoice) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    auto metadata = [&](const std::string& name, const std::string& extra) {
        const std::string out = dir.file(name + ".exr");
        const std::string cmd = tool("render") + " " + scene + " -q --spp 16 --set pilot=on --atlas " +
                                dir.file("atlas.h5") + " -o " + out + " " + extra;
        ToolResult r = run_command(cmd);
        EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
        return r.status == 0 ? read_exr(out).metadata : std::map<std::string, std::string>{};
    };
    auto has = [](const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; };

    auto m = metadata("default", "");
    const std::string pilot = m["iris:auto_guide"];
    EXPECT_TRUE(has(pilot, "unguided ")) << pilot;
    EXPECT_TRUE(has(pilot, "first vertex, roulette below 0.3 from depth 5 ")) << pilot;
    EXPECT_TRUE(has(pilot, "every vertex, roulette below 0.1 from depth 5 ")) << pilot;
    // The setting rendered is the one the pilot names first (or none: unguided).
    if (m["iris:mode"] == "nee+bsdf") {
        EXPECT_TRUE(has(pilot, "unguided:")) << pilot;
        EXPECT_EQ(m.count("iris:guiding"), 0u);
    } else {
        EXPECT_TRUE(has(pilot, "guided (" + m["iris:guiding"] + ")")) << pilot;
    }
    // It weighs light tracing of the caustics too (on the caustic box the caustic beside the sphere is
    // about a tenth of the image, far above kMinCausticShare), and renders what it chose.
    EXPECT_TRUE(has(pilot, ", caustics light-traced (")) << pilot;
    EXPECT_TRUE(has(m["iris:caustics"], "light-traced, ")) << m["iris:caustics"];
    EXPECT_NE(m["iris:light_paths"], "0");

    m = metadata("two", "--set guide-vertices=2");
    EXPECT_TRUE(has(m["iris:auto_guide"], "first 2 vertices, roulette below 0.3 from depth 5 ")) << m["iris:auto_guide"];
    EXPECT_FALSE(has(m["iris:auto_guide"], "every vertex")) << m["iris:auto_guide"];

    m = metadata("rr", "--set rr-depth=7");
    EXPECT_TRUE(has(m["iris:auto_guide"], "first vertex, roulette below 0.3 from depth 7 ")) << m["iris:auto_guide"];
    EXPECT_FALSE(has(m["iris:auto_guide"], "every vertex")) << m["iris:auto_guide"];

    m = metadata("threshold", "--set rr-threshold=1");
    EXPECT_TRUE(has(m["iris:auto_guide"], "first vertex, roulette below 1 from depth 5 ")) << m["iris:auto_guide"];
    EXPECT_FALSE(has(m["iris:auto_guide"], "every vertex")) << m["iris:auto_guide"];
}

}  // namespace

namespace {

// The path tracer with NEE and MIS against BSDF sampling alone, per pixel, on `scene_file` for each of
// `variants` (extra render arguments): 1024 and 4096 samples (BSDF sampling alone finds small emitters
// rarely: the heavier tail); an image 5 % too bright must be rejected. Pixels whose values are all but
// zero are left out: a few samples of 1e-28 (a microfacet lobe's far tail) underflow the float variance
// layer to 0, an infinite z for any difference. The images' values are 0.01 to 5.
void expect_nee_agrees_with_bsdf_sampling(const std::string& scene_file, const std::vector<std::string>& variants) {
    TempDir dir;
    const std::string scene = data_file(scene_file);
    for (const std::string& variant : variants) {
        SCOPED_TRACE(variant);
        const Layers nee = render(scene, dir, "nee", "--spp 1024 --seed 1 " + variant);
        const Layers bsdf = render(scene, dir, "bsdf", "--set mode=bsdf+cache --set pilot=off --spp 4096 --seed 2 " + variant);
        ASSERT_EQ(nee.w, 16);
        ASSERT_EQ(bsdf.w, nee.w);
        const double z_crit = normal_critical(kAlpha / test_count(nee, 2 * int(variants.size())));
        std::vector<char> skip(size_t(nee.w * nee.h), 0);
        for (size_t i = 0; i < skip.size(); ++i)
            for (int c = 0; c < 3; ++c)
                skip[i] |= std::max(nee.value[c][i], bsdf.value[c][i]) < 1e-12 ? 1 : 0;
        const Verdict v = compare(nee, bsdf, 1.0, z_crit, &skip);
        std::printf("%-28s largest |z|: pixel %.2f (%s), block %.2f, image %.2f\n", variant.c_str(), v.worst_z[0],
                    v.worst_where[0].c_str(), v.worst_z[1], v.worst_z[2]);
        EXPECT_EQ(v.rejections, 0) << "NEE and BSDF sampling disagree on " << scene_file << ":\n" << v.log;
        const Verdict biased = compare(nee, bsdf, 1.05, z_crit, &skip);
        std::printf("%-28s x 1.05:      pixel %.2f, block %.2f, image %.2f\n", variant.c_str(), biased.worst_z[0],
                    biased.worst_z[1], biased.worst_z[2]);
        EXPECT_GT(biased.rejections, 0) << "the test cannot tell a 5 % bias";
    }
}

// Rough glass (roughdielectric) seen by light samples and by BSDF samples: on one rough interface with
// emitters and a wall beyond it (tests/data/render/rough_interface.xml), NEE's shadow rays reach an emitter
// through the interface, so its BSDF value must carry radiance's 1/eta^2 and MIS the refraction's density,
// while BSDF sampling alone takes its weights from bsdf_sample; both microfacet distributions. Checked to
// fail: NEE evaluating the BSDF in importance mode is rejected (block |z| 13-26).
TEST(EstimatorsAgree, RoughGlassNeeAndBsdfSampling) {
    expect_nee_agrees_with_bsdf_sampling("render/rough_interface.xml", {"-D distribution=beckmann", "-D distribution=ggx"});
}

// Bump mapping (bumpmap): a rough plastic floor whose shading normals a height map tilts by up to ~40
// degrees (tests/data/render/bumped_plane.xml), where light samples and BSDF samples meet the shading and
// geometric normals' disagreement from both sides.
TEST(EstimatorsAgree, BumpMappedFloorNeeAndBsdfSampling) {
    expect_nee_agrees_with_bsdf_sampling("render/bumped_plane.xml", {""});
}

}  // namespace

namespace {

// Masks (`mask`, tests/data/render/masked_blinds.xml: blinds of textured opacity between a light and the
// floor, a standing panel of constant opacity 0.6, a mirror ball making caustics through the blinds).
// Accel's filter lets rays through for every estimator alike: NEE's shadow rays and BSDF-sampled rays
// must agree per pixel (light through the blinds reaches the floor both ways). The ball is rough here:
// a mirror's caustics would only add fireflies to both renders.
TEST(EstimatorsAgree, MaskedBlindsNeeAndBsdfSampling) {
    expect_nee_agrees_with_bsdf_sampling("render/masked_blinds.xml", {"-D ball=roughconductor"});
}

// The same scene through the whole pipeline: photons and caches pass the masks as the paths do; guided
// rendering (every vertex), the caustic light tracer and the caustic connections (their light paths
// pass the blinds too) agree with the unguided path tracer per pixel.
TEST(GuidingUnbiased, MaskedSceneAgreesPerPixel) {
    TempDir dir;
    const std::string scene = data_file("render/masked_blinds.xml");
    ASSERT_TRUE(build_atlases(scene, dir));
    const std::string atlas = " --atlas " + dir.file("atlas.h5");
    expect_agrees_per_pixel(scene, dir, 1024,
                            {{"every vertex guided", "--set mode=nee+bsdf+cache --set pilot=off --set guide-vertices=0 --set rr-threshold=0.1" + atlas},
                             {"light-traced, connected", "--set mode=nee+cache --set pilot=off --set caustics=on --set connect=on" + atlas}});
}

}  // namespace
