// The command-line contract of the three preprocessing stages (trace-photons, place-caches,
// fill-caches) on good input: silent with -q, and deterministic for a seed whatever the thread count
// (STYLE.md habit 5). Bad input is catalogued in test_bad_input.cpp.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/exr.h"
#include "formats/photon_map.h"
#include "support/run_tool.h"

namespace fs = std::filesystem;
using namespace iris;
using namespace iris::test;

namespace {

// Photons of the caustic scene, shared by every test here, made once.
class GuidingCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = new TempDir;
        const std::string q = " -q --seed 5";
        auto run = [](const std::string& cmd) {
            ToolResult r = run_command(cmd);
            ASSERT_EQ(r.status, 0) << cmd << "\n" << r.output;
        };
        run(tool("trace-photons") + " " + scene() + " -o " + in("photons.h5") + " --set photon-paths=3000" + q);
    }
    static void TearDownTestSuite() {
        delete dir_;
        dir_ = nullptr;
    }
    static std::string scene() { return data_file("guiding/caustic_box.xml"); }
    static std::string in(const std::string& name) { return dir_->file(name); }
    // Runs a tool command that must succeed; its result, for the output.
    static ToolResult run_ok(const std::string& cmd) {
        ToolResult r = run_command(cmd);
        EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
        return r;
    }

    static TempDir* dir_;
};
TempDir* GuidingCli::dir_ = nullptr;

TEST_F(GuidingCli, QuietSuccessPrintsNothing) {
    TempDir d;
    ToolResult r = run_command(tool("trace-photons") + " " + scene() + " -q --set photon-paths=200 -o " + d.file("p.h5"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.output, "");
    r = run_command(tool("place-caches") + " " + scene() + " --photon-map " + d.file("p.h5") + " -q --set cache-count=10 -o " +
                    d.file("c.h5"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.output, "");
    r = run_command(tool("fill-caches") + " " + d.file("c.h5") + " --photon-map " + d.file("p.h5") + " -q --set gather-count=20 -o " +
                    d.file("a.h5"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.output, "");
}

// Same seed, one thread or two: the same photons, in the same order, bit for bit (randomness comes from
// the path index, never from the thread). A different seed gives different photons.
TEST_F(GuidingCli, TracePhotonsIsDeterministicForAnyThreadCount) {
    TempDir d;
    auto trace = [&](const std::string& name, const std::string& extra) {
        ToolResult r = run_command(tool("trace-photons") + " " + scene() + " -q --set photon-paths=5000 -o " + d.file(name) + extra);
        EXPECT_EQ(r.status, 0) << r.output;
        return read_photon_map(d.file(name)).photons;
    };
    // 5000 paths are 5 work chunks of 1024: two threads really do split the work.
    PhotonMap a = trace("a.h5", " --seed 3 -t 1"), b = trace("b.h5", " --seed 3 -t 2");
    ASSERT_GT(a.size(), 5000u);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(a.emitted_paths, b.emitted_paths);
    EXPECT_EQ(a.max_depth, b.max_depth);
    size_t differ = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        bool same = true;
        for (int k = 0; k < 3; ++k)
            same = same && a.position[i][k] == b.position[i][k] && a.direction[i][k] == b.direction[i][k] &&
                   a.normal[i][k] == b.normal[i][k] && a.power[i][k] == b.power[i][k];
        differ += !same;
    }
    EXPECT_EQ(differ, 0u) << "photons differ between -t 1 and -t 2";
    PhotonMap c = trace("c.h5", " --seed 4 -t 2");
    EXPECT_TRUE(c.size() != a.size() || c.position[0][0] != a.position[0][0]) << "the seed has no effect";
}

// photon-count=M: the path count comes from photons per path on a probe of the first paths, so the map
// holds about M photons and is, bit for bit, the map of photon-paths with that count; the count does not depend
// on the thread count.
TEST_F(GuidingCli, TracePhotonsByPhotonCountIsTheMapOfItsPathCount) {
    TempDir d;
    const uint64_t target = 150000;
    const std::string base = tool("trace-photons") + " " + scene() + " -q --seed 3 --set photon-depth=6";
    run_ok(base + " --set photon-count=" + std::to_string(target) + " -t 2 -o " + d.file("m.h5"));
    run_ok(base + " --set photon-count=" + std::to_string(target) + " -t 1 -o " + d.file("m1.h5"));
    const PhotonMapFile m = read_photon_map(d.file("m.h5"));
    // Photons per path on 32768 paths is within a few percent of the whole run's.
    EXPECT_GT(m.photons.size(), target * 95 / 100);
    EXPECT_LT(m.photons.size(), target * 105 / 100);
    EXPECT_GT(m.photons.emitted_paths, 32768u);  // not the probe's count: the target needs more paths
    EXPECT_EQ(read_photon_map(d.file("m1.h5")).photons.emitted_paths, m.photons.emitted_paths);
    EXPECT_EQ(m.header.provenance.parameters.at("photons_target"), double(target));
    run_ok(base + " --set photon-paths=" + std::to_string(m.photons.emitted_paths) + " -t 2 -o " + d.file("p.h5"));
    const PhotonMap p = read_photon_map(d.file("p.h5")).photons;
    ASSERT_EQ(p.size(), m.photons.size());
    EXPECT_EQ(std::memcmp(p.power.data(), m.photons.power.data(), p.size() * sizeof(RGB)), 0);
    EXPECT_EQ(std::memcmp(p.position.data(), m.photons.position.data(), p.size() * sizeof(Vec3)), 0);
}

TEST_F(GuidingCli, PlaceAndFillCachesAreDeterministicForAnyThreadCount) {
    TempDir d;
    const std::string place = tool("place-caches") + " " + scene() + " --photon-map " + in("photons.h5") + " -q --set cache-count=80";
    const std::string fill = tool("fill-caches") + " ";
    for (const char* t : {"1", "2"}) {
        ToolResult r = run_command(place + " -t " + t + " -o " + d.file(std::string("c") + t + ".h5"));
        ASSERT_EQ(r.status, 0) << r.output;
        r = run_command(fill + d.file(std::string("c") + t + ".h5") + " --photon-map " + in("photons.h5") +
                        " -q --set gather-count=80 --set map-resolution=8 -t " + t + " -o " + d.file(std::string("a") + t + ".h5"));
        ASSERT_EQ(r.status, 0) << r.output;
    }
    CachePoints c1 = read_cache_points(d.file("c1.h5")).caches, c2 = read_cache_points(d.file("c2.h5")).caches;
    ASSERT_EQ(c1.size(), c2.size());
    for (size_t i = 0; i < c1.size(); ++i) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(c1.position[i][k], c2.position[i][k]) << "cache " << i;
            EXPECT_EQ(c1.normal[i][k], c2.normal[i][k]) << "cache " << i;
        }
        EXPECT_EQ(c1.origin[i], c2.origin[i]);
    }
    CacheAtlas a1 = read_cache_atlas(d.file("a1.h5")).atlas, a2 = read_cache_atlas(d.file("a2.h5")).atlas;
    EXPECT_EQ(a1.pdf, a2.pdf);
    EXPECT_EQ(a1.cdf, a2.cdf);
    EXPECT_EQ(a1.photon_count, a2.photon_count);
    EXPECT_EQ(a1.usable, a2.usable);
}

// Skipping what a scene does not need: with min-caustic-share, place-caches places no cache where
// less than that share of the photon power came through a specular chain, says so even with -q, and
// the empty set flows through fill-caches to a render that stays unguided (no pilot) and records why.
// The caustic box (glass sphere) keeps its caches at the pipeline's default share.
TEST_F(GuidingCli, NoCachesWithoutLightThroughSpecularChains) {
    TempDir d;
    const std::string diffuse = data_file("render/sphere_light_over_plane.xml");
    run_ok(tool("trace-photons") + " " + diffuse + " -q --set photon-paths=3000 --seed 5 -o " + d.file("p.h5"));
    // trace-photons records the share (place-caches then decides from the header alone): none here,
    // some on the caustic box.
    EXPECT_EQ(read_photon_map_header(d.file("p.h5")).provenance.parameters.at("caustic_share"), 0.0);
    EXPECT_GT(read_photon_map_header(in("photons.h5")).provenance.parameters.at("caustic_share"), 0.0);
    ToolResult r = run_ok(tool("place-caches") + " " + diffuse + " --photon-map " + d.file("p.h5") +
                       " -q --set cache-count=50 --set min-caustic-share=0.005 -o " + d.file("c.h5"));
    EXPECT_NE(r.output.find("no caches: 0.00 % of the photon power arrives through specular chains"), std::string::npos)
        << r.output;
    EXPECT_EQ(read_cache_points(d.file("c.h5")).caches.size(), 0u);
    run_ok(tool("fill-caches") + " " + d.file("c.h5") + " --photon-map " + d.file("p.h5") + " -q -o " + d.file("a.h5"));
    EXPECT_EQ(read_cache_atlas(d.file("a.h5")).atlas.size(), 0u);
    run_ok(tool("render") + " " + diffuse + " -q --spp 4 --set pilot=on --atlas " + d.file("a.h5") + " -o " + d.file("g.exr"));
    const Image img = read_exr(d.file("g.exr"));
    EXPECT_EQ(img.metadata.at("iris:mode"), "nee+bsdf");
    EXPECT_EQ(img.metadata.at("iris:auto_guide"), "unguided: no cache in the atlas guides");

    // The same share on the caustic box: its glass sphere carries light, caches are placed.
    r = run_ok(tool("place-caches") + " " + scene() + " --photon-map " + in("photons.h5") +
            " -q --set cache-count=50 --set min-caustic-share=0.005 -o " + d.file("cc.h5"));
    EXPECT_EQ(r.output, "");
    EXPECT_GT(read_cache_points(d.file("cc.h5")).caches.size(), 0u);
}

// With the same threshold, trace-photons traces nothing where no surface has a Dirac lobe (the share is
// 0 whatever the photons): an empty photon map recording share 0, said even with -q, from which the
// rest of the pipeline renders unguided. A scene with a specular surface is traced as without it.
TEST_F(GuidingCli, NoPhotonsWithoutSpecularSurfaces) {
    TempDir d;
    const std::string diffuse = data_file("render/sphere_light_over_plane.xml");
    ToolResult r = run_ok(tool("trace-photons") + " " + diffuse + " -q --set photon-paths=3000 --set min-caustic-share=0.005 -o " + d.file("p.h5"));
    EXPECT_NE(r.output.find("has a specular (Dirac) lobe, so no light arrives through specular chains"), std::string::npos)
        << r.output;
    const PhotonMapFile pm = read_photon_map(d.file("p.h5"), "");
    EXPECT_EQ(pm.photons.size(), 0u);
    EXPECT_EQ(pm.header.provenance.parameters.at("caustic_share"), 0.0);
    EXPECT_EQ(pm.header.provenance.parameters.at("paths"), 0.0);
    run_ok(tool("place-caches") + " " + diffuse + " --photon-map " + d.file("p.h5") + " -q --set cache-count=50 --set min-caustic-share=0.005 -o " +
        d.file("c.h5"));
    EXPECT_EQ(read_cache_points(d.file("c.h5")).caches.size(), 0u);
    run_ok(tool("fill-caches") + " " + d.file("c.h5") + " --photon-map " + d.file("p.h5") + " -q -o " + d.file("a.h5"));
    run_ok(tool("render") + " " + diffuse + " -q --spp 4 --set pilot=on --atlas " + d.file("a.h5") + " -o " + d.file("g.exr"));
    EXPECT_EQ(read_exr(d.file("g.exr")).metadata.at("iris:mode"), "nee+bsdf");

    r = run_ok(tool("trace-photons") + " " + scene() + " -q --set photon-paths=2000 --set min-caustic-share=0.005 -o " + d.file("pc.h5"));
    EXPECT_EQ(r.output, "");
    EXPECT_GT(read_photon_map(d.file("pc.h5"), "").photons.size(), 0u);
}

// The render's work counters in the image's metadata (what `python3 -m scripts.bench cost` splits the per-sample cost
// by): unguided, no cache lookups; guiding the first vertex, at most one per path and some; guiding every
// vertex, more; and at least one ray per path in every render.
TEST_F(GuidingCli, RenderRecordsItsRaysAndCacheLookups) {
    TempDir d;
    run_ok(tool("place-caches") + " " + scene() + " --photon-map " + in("photons.h5") + " -q --set cache-count=50 -o " + d.file("c.h5"));
    run_ok(tool("fill-caches") + " " + d.file("c.h5") + " --photon-map " + in("photons.h5") + " -q --set gather-count=40 --set map-resolution=8 -o " +
           d.file("a.h5"));
    auto counts = [&](const std::string& name, const std::string& args) {
        run_ok(tool("render") + " " + scene() + " -q --spp 4 --seed 3 " + args + " -o " + d.file(name));
        const Image img = read_exr(d.file(name));
        const uint64_t paths = uint64_t(img.width) * uint64_t(img.height) * 4;
        EXPECT_GE(std::stoull(img.metadata.at("iris:rays")), paths) << name;
        return std::pair{std::stoull(img.metadata.at("iris:cache_lookups")), paths};
    };
    EXPECT_EQ(counts("u.exr", "--set mode=nee+bsdf").first, 0u);
    const auto [first, paths] = counts("f.exr", "--set mode=nee+bsdf+cache --set pilot=off --atlas " + d.file("a.h5") + " --set guide-vertices=1");
    EXPECT_GT(first, 0u);
    EXPECT_LE(first, paths);
    const auto every = counts("e.exr", "--set mode=nee+bsdf+cache --set pilot=off --atlas " + d.file("a.h5") + " --set guide-vertices=0").first;
    EXPECT_GT(every, first);
}

}  // namespace
