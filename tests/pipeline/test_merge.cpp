// Splitting a stage across processes (render --sample-range, trace-photons --path-range) and joining the
// parts (merge-images, merge-photons) gives the file of one run: the photon map bit for bit, the image
// bit for bit except where the film's double sums, added part by part instead of sample by sample,
// round differently (then within 1e-6 relative; the test counts those pixels and requires few).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "formats/exr.h"
#include "formats/photon_map.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

void run_ok(const std::string& cmd) {
    ToolResult r = run_command(cmd);
    ASSERT_EQ(r.status, 0) << cmd << "\n" << r.output;
}

// Every channel of `merged` against `single`: within 1e-6 relative everywhere; returns the number of
// values that are not bit-identical.
size_t compare_images(const Image& merged, const Image& single) {
    EXPECT_EQ(merged.width, single.width);
    EXPECT_EQ(merged.height, single.height);
    EXPECT_EQ(merged.channels.size(), single.channels.size());
    size_t differing = 0;
    for (size_t c = 0; c < single.channels.size(); ++c) {
        const int m = merged.channel_index(single.channels[c]);
        EXPECT_GE(m, 0) << single.channels[c];
        if (m < 0) continue;
        for (size_t i = 0; i < single.data[c].size(); ++i) {
            const float a = merged.data[size_t(m)][i], b = single.data[c][i];
            if (a != b) ++differing;
            EXPECT_LE(std::abs(a - b), 1e-6f * std::abs(b)) << single.channels[c] << " pixel " << i;
        }
    }
    return differing;
}

void expect_same_metadata(const Image& merged, const Image& single) {
    for (const char* key : {"iris:spp", "iris:seed", "iris:scene_fingerprint", "iris:max_depth", "iris:mode",
                            "iris:light_paths", "iris:nonfinite_samples", "iris:rays", "iris:cache_lookups",
                            "iris:guiding", "iris:caustics"})
        EXPECT_EQ(merged.metadata.count(key) ? merged.metadata.at(key) : "-",
                  single.metadata.count(key) ? single.metadata.at(key) : "-")
            << key;
    EXPECT_EQ(merged.metadata.count("iris:sample_range"), 0u);
    EXPECT_EQ(merged.channel_index("part.count"), -1) << "the merged image carries no part channels";
}

}  // namespace

// A guided render (the golden atlas of the caustic box) in three uneven ranges given out of order, with
// variance and sample-count layers.
TEST(Merge, GuidedRenderRangesComposeToOneRun) {
    TempDir dir;
    const std::string base = tool("render") + " " + data_file("guiding/caustic_box.xml") + " --atlas " +
                             std::string(IRIS_SOURCE_DIR) + "/tests/golden/atlas.h5 --set mode=nee+bsdf+cache --set pilot=off --spp 24 " +
                             "--resolution 40x40 --seed 5 --variance --set samples-layer=on -q";
    run_ok(base + " -o " + dir.file("single.exr"));
    run_ok(base + " --sample-range 0:7 -o " + dir.file("a.exr"));
    run_ok(base + " --sample-range 7:16 -o " + dir.file("b.exr"));
    run_ok(base + " --sample-range 16:24 -t 1 -o " + dir.file("c.exr"));
    run_ok(tool("merge-images") + " -q " + dir.file("c.exr") + " " + dir.file("a.exr") + " " + dir.file("b.exr") +
           " -o " + dir.file("merged.exr"));
    const Image single = read_exr(dir.file("single.exr")), merged = read_exr(dir.file("merged.exr"));
    const size_t differing = compare_images(merged, single);
    // R, G, B, variance: at most a handful of last-bit differences (double rounding order).
    EXPECT_LE(differing, size_t(single.width) * single.height * single.channels.size() / 100) << differing;
    std::printf("guided, 3 parts: %zu of %zu values not bit-identical\n", differing,
                size_t(single.width) * single.height * single.channels.size());
    expect_same_metadata(merged, single);
    // compare-images accepts it, and sees no difference.
    ToolResult r = run_command(tool("compare-images") + " " + dir.file("merged.exr") + " " + dir.file("single.exr") +
                               " --max-relmse 1e-10");
    EXPECT_EQ(r.status, 0) << r.output;
}

// The caustic light tracer (caustics=on): its splats' sums merge too.
TEST(Merge, LightTracedRenderRangesComposeToOneRun) {
    TempDir dir;
    const std::string base = tool("render") + " " + data_file("guiding/caustic_box.xml") +
                             " --set caustics=on --spp 12 --resolution 32x32 --seed 2 --variance -q";
    run_ok(base + " -o " + dir.file("single.exr"));
    run_ok(base + " --sample-range 0:5 -o " + dir.file("a.exr"));
    run_ok(base + " --sample-range 5:12 -o " + dir.file("b.exr"));
    run_ok(tool("merge-images") + " -q " + dir.file("a.exr") + " " + dir.file("b.exr") + " -o " + dir.file("merged.exr"));
    const Image single = read_exr(dir.file("single.exr")), merged = read_exr(dir.file("merged.exr"));
    const size_t differing = compare_images(merged, single);
    EXPECT_LE(differing, size_t(single.width) * single.height * single.channels.size() / 100) << differing;
    expect_same_metadata(merged, single);
}

// Photon paths in three ranges: the merged map's photons are the single run's, bit for bit, and
// place-caches takes it.
TEST(Merge, PhotonRangesComposeToOneRunBitForBit) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    const std::string base = tool("trace-photons") + " " + scene + " --set photon-paths=5000 --set photon-depth=6 --seed 11 -q";
    run_ok(base + " -o " + dir.file("single.h5"));
    run_ok(base + " --path-range 0:1500 -o " + dir.file("a.h5"));
    run_ok(base + " --path-range 1500:1501 -t 1 -o " + dir.file("b.h5"));
    run_ok(base + " --path-range 1501:5000 -o " + dir.file("c.h5"));
    run_ok(tool("merge-photons") + " -q " + dir.file("c.h5") + " " + dir.file("b.h5") + " " + dir.file("a.h5") + " -o " +
           dir.file("merged.h5"));
    const PhotonMapFile s = read_photon_map(dir.file("single.h5")), m = read_photon_map(dir.file("merged.h5"));
    ASSERT_EQ(m.photons.size(), s.photons.size());
    ASSERT_GT(s.photons.size(), 1000u);
    EXPECT_EQ(m.photons.emitted_paths, s.photons.emitted_paths);
    EXPECT_EQ(m.photons.max_depth, s.photons.max_depth);
    EXPECT_EQ(m.header.scene_fingerprint, s.header.scene_fingerprint);
    for (size_t i = 0; i < s.photons.size(); ++i) {
        ASSERT_EQ(std::memcmp(&m.photons.position[i], &s.photons.position[i], sizeof(Vec3)), 0) << i;
        ASSERT_EQ(std::memcmp(&m.photons.direction[i], &s.photons.direction[i], sizeof(Vec3)), 0) << i;
        ASSERT_EQ(std::memcmp(&m.photons.normal[i], &s.photons.normal[i], sizeof(Vec3)), 0) << i;
        ASSERT_EQ(std::memcmp(&m.photons.power[i], &s.photons.power[i], sizeof(RGB)), 0) << i;
    }
    EXPECT_EQ(m.photons.bounces, s.photons.bounces);
    EXPECT_EQ(m.photons.caustic, s.photons.caustic);
    const auto& mp = m.header.provenance.parameters;
    const auto& sp = s.header.provenance.parameters;
    for (const char* key : {"paths", "max_depth", "rr_depth", "cutoff", "caustic_share", "min_caustic_share"})
        EXPECT_EQ(mp.at(key), sp.at(key)) << key;
    EXPECT_EQ(mp.count("path_total"), 0u);
    run_ok(tool("place-caches") + " " + scene + " --photon-map " + dir.file("merged.h5") + " -o " + dir.file("caches.h5") +
           " --set cache-count=16 -q");
}
