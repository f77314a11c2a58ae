// The command-line contract of the three preprocessing stages (trace-photons, place-caches,
// fill-caches), DESIGN.md section 3: every bad invocation -- a bad flag value, a missing or unreadable
// input, a stage file of the wrong kind or made for another scene, an output that cannot be written --
// exits non-zero with exactly one line on stderr, "TOOL: error: ...", naming the problem, and leaves no
// output file (nor a temporary one) behind. And the results are deterministic for a seed whatever the
// thread count (STYLE.md habit 5).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/photon_map.h"
#include "support/run_tool.h"

namespace fs = std::filesystem;
using namespace iris;
using namespace iris::test;

namespace {

// Lines of a tool's output (stdout and stderr merged), without empty ones.
std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> out;
    size_t start = 0;
    while (start < text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        if (end > start) out.push_back(text.substr(start, end - start));
        start = end + 1;
    }
    return out;
}

std::vector<std::string> entries(const fs::path& dir) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
    return out;
}

// Stage files shared by every test here, made once: photons, caches and an atlas of the caustic scene,
// photons of another scene (the furnace box), and a text file that is no HDF5 file at all.
class GuidingCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = new TempDir;
        const std::string q = " -q --seed 5";
        auto run = [](const std::string& cmd) {
            ToolResult r = run_command(cmd);
            ASSERT_EQ(r.status, 0) << cmd << "\n" << r.output;
        };
        run(tool("trace-photons") + " " + scene() + " -o " + in("photons.h5") + " --paths 3000" + q);
        run(tool("trace-photons") + " " + data_file("render/furnace_box.xml") + " -o " + in("furnace_photons.h5") +
            " --paths 1000" + q);
        run(tool("place-caches") + " " + scene() + " --photons " + in("photons.h5") + " -o " + in("caches.h5") +
            " --count 60" + q);
        run(tool("fill-caches") + " " + in("caches.h5") + " --photons " + in("photons.h5") + " -o " + in("atlas.h5") +
            " --k 100 --resolution 8" + q);
        std::ofstream(in("text.h5")) << "not an HDF5 file\n";
    }
    static void TearDownTestSuite() {
        delete dir_;
        dir_ = nullptr;
    }
    static std::string scene() { return data_file("guiding/caustic_box.xml"); }
    static std::string in(const std::string& name) { return dir_->file(name); }

    // Runs `tool_name args -o OUT` (OUT in a fresh, empty directory) and checks the whole contract.
    static void expect_refusal(const std::string& tool_name, const std::string& args, const std::string& mention,
                               const std::string& out_path = "") {
        TempDir out_dir;
        const std::string out = out_path.empty() ? out_dir.file("out.h5") : out_path;
        const std::string cmd = tool(tool_name) + " " + args + " -o " + out;
        ToolResult r = run_command(cmd);
        SCOPED_TRACE(cmd);
        EXPECT_NE(r.status, 0) << r.output;
        std::vector<std::string> ls = lines_of(r.output);
        ASSERT_EQ(ls.size(), 1u) << "expected exactly one line of output, got:\n" << r.output;
        EXPECT_EQ(ls[0].rfind(tool_name + ": error: ", 0), 0u) << ls[0];
        EXPECT_NE(ls[0].find(mention), std::string::npos) << "the error should mention \"" << mention << "\": " << ls[0];
        if (out_path.empty() || !fs::is_directory(out_path))  // (an output path that is a directory stays one)
            EXPECT_FALSE(fs::exists(out)) << "an output file was left behind";
        EXPECT_TRUE(entries(out_dir.path).empty()) << "something (a temporary file?) was left in the output directory";
    }

    static TempDir* dir_;
};
TempDir* GuidingCli::dir_ = nullptr;

TEST_F(GuidingCli, TracePhotonsRefusesBadFlags) {
    const std::string s = scene() + " -q";
    expect_refusal("trace-photons", s + " --paths 0", "--paths");
    // A negative count once wrapped around to 2^64 - 5 paths, traced none and exited 0.
    expect_refusal("trace-photons", s + " --paths -5", "--paths");
    expect_refusal("trace-photons", s + " --paths abc", "--paths");
    expect_refusal("trace-photons", s + " --max-depth 0", "--max-depth");
    expect_refusal("trace-photons", s + " --max-depth -3", "--max-depth");
    expect_refusal("trace-photons", s + " --rr-depth 0", "--rr-depth");
    expect_refusal("trace-photons", s + " --cutoff 1", "--cutoff");
    expect_refusal("trace-photons", s + " -t -1", "--threads");
    expect_refusal("trace-photons", s + " --no-such-flag 3", "--no-such-flag");
}

TEST_F(GuidingCli, TracePhotonsRefusesMissingOrBadScene) {
    expect_refusal("trace-photons", in("missing.xml") + " -q", "missing.xml");
    expect_refusal("trace-photons", in("text.h5") + " -q", "text.h5");  // not XML
}

TEST_F(GuidingCli, PlaceCachesRefusesBadFlags) {
    const std::string s = scene() + " --photons " + in("photons.h5") + " -q";
    expect_refusal("place-caches", s + " --count 0", "--count");
    expect_refusal("place-caches", s + " --count -3", "--count");
    expect_refusal("place-caches", s + " --camera-stride -1", "--camera-stride");
    expect_refusal("place-caches", s + " --resolution 0x4", "--resolution");
    expect_refusal("place-caches", s + " -t -1", "--threads");
    expect_refusal("place-caches", scene() + " -q", "--photons");  // a required option left out
}

TEST_F(GuidingCli, PlaceCachesRefusesBadInputs) {
    expect_refusal("place-caches", in("missing.xml") + " --photons " + in("photons.h5") + " -q", "missing.xml");
    expect_refusal("place-caches", scene() + " --photons " + in("missing.h5") + " -q", "missing.h5");
    // Photons of the furnace box for the caustic scene: the fingerprints differ.
    expect_refusal("place-caches", scene() + " --photons " + in("furnace_photons.h5") + " -q", "another scene");
    // Another kind of stage file, and a file that is no HDF5 file.
    expect_refusal("place-caches", scene() + " --photons " + in("atlas.h5") + " -q", "iris-cache-atlas");
    expect_refusal("place-caches", scene() + " --photons " + in("caches.h5") + " -q", "iris-cache-points");
    expect_refusal("place-caches", scene() + " --photons " + in("text.h5") + " -q", "not an HDF5 file");
}

TEST_F(GuidingCli, FillCachesRefusesBadFlags) {
    const std::string s = in("caches.h5") + " --photons " + in("photons.h5") + " -q";
    expect_refusal("fill-caches", s + " --k 0", "--k");
    expect_refusal("fill-caches", s + " --k -2", "--k");
    expect_refusal("fill-caches", s + " --resolution 0", "--resolution");
    expect_refusal("fill-caches", s + " --resolution 257", "--resolution");
    expect_refusal("fill-caches", s + " --floor 0", "--floor");
    expect_refusal("fill-caches", s + " --floor 1.5", "--floor");
    expect_refusal("fill-caches", s + " --max-radius 0", "--max-radius");
    expect_refusal("fill-caches", s + " --filter-sigma -1", "--filter-sigma");
    expect_refusal("fill-caches", s + " -t -1", "--threads");
}

TEST_F(GuidingCli, FillCachesRefusesBadInputs) {
    expect_refusal("fill-caches", in("missing.h5") + " --photons " + in("photons.h5") + " -q", "missing.h5");
    expect_refusal("fill-caches", in("caches.h5") + " --photons " + in("missing.h5") + " -q", "missing.h5");
    // Caches of the caustic scene with photons of the furnace box.
    expect_refusal("fill-caches", in("caches.h5") + " --photons " + in("furnace_photons.h5") + " -q", "another scene");
    // Wrong kinds: an atlas as the photons, photons as the caches, and a text file.
    expect_refusal("fill-caches", in("caches.h5") + " --photons " + in("atlas.h5") + " -q", "iris-cache-atlas");
    expect_refusal("fill-caches", in("photons.h5") + " --photons " + in("photons.h5") + " -q", "iris-photon-map");
    expect_refusal("fill-caches", in("text.h5") + " --photons " + in("photons.h5") + " -q", "not an HDF5 file");
}

TEST_F(GuidingCli, EveryStageRefusesAnUnwritableOutput) {
    const std::string trace = scene() + " -q --paths 100";
    const std::string place = scene() + " --photons " + in("photons.h5") + " -q --count 10";
    const std::string fill = in("caches.h5") + " --photons " + in("photons.h5") + " -q --k 50";
    // (The tests may run as root, for whom a read-only directory is writable: use a missing directory
    // and a path that is a directory instead.)
    TempDir d;
    fs::create_directory(d.file("adir"));
    const struct {
        std::string tool, args;
    } cases[] = {{"trace-photons", trace}, {"place-caches", place}, {"fill-caches", fill}};
    for (const auto& c : cases) {
        expect_refusal(c.tool, c.args, "/nonexistent-dir/x.h5", "/nonexistent-dir/x.h5");
        expect_refusal(c.tool, c.args, "directory", d.file("adir"));
        EXPECT_TRUE(fs::is_directory(d.file("adir"))) << c.tool << " replaced a directory";
    }
    EXPECT_EQ(entries(d.path), std::vector<std::string>{"adir"}) << "a temporary file was left beside the directory";
}

TEST_F(GuidingCli, QuietSuccessPrintsNothing) {
    TempDir d;
    ToolResult r = run_command(tool("trace-photons") + " " + scene() + " -q --paths 200 -o " + d.file("p.h5"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.output, "");
    r = run_command(tool("place-caches") + " " + scene() + " --photons " + d.file("p.h5") + " -q --count 10 -o " +
                    d.file("c.h5"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.output, "");
    r = run_command(tool("fill-caches") + " " + d.file("c.h5") + " --photons " + d.file("p.h5") + " -q --k 20 -o " +
                    d.file("a.h5"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.output, "");
}

// Same seed, one thread or two: the same photons, in the same order, bit for bit (randomness comes from
// the path index, never from the thread). A different seed gives different photons.
TEST_F(GuidingCli, TracePhotonsIsDeterministicForAnyThreadCount) {
    TempDir d;
    auto trace = [&](const std::string& name, const std::string& extra) {
        ToolResult r = run_command(tool("trace-photons") + " " + scene() + " -q --paths 5000 -o " + d.file(name) + extra);
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

TEST_F(GuidingCli, PlaceAndFillCachesAreDeterministicForAnyThreadCount) {
    TempDir d;
    const std::string place = tool("place-caches") + " " + scene() + " --photons " + in("photons.h5") + " -q --count 80";
    const std::string fill = tool("fill-caches") + " ";
    for (const char* t : {"1", "2"}) {
        ToolResult r = run_command(place + " -t " + t + " -o " + d.file(std::string("c") + t + ".h5"));
        ASSERT_EQ(r.status, 0) << r.output;
        r = run_command(fill + d.file(std::string("c") + t + ".h5") + " --photons " + in("photons.h5") +
                        " -q --k 80 --resolution 8 -t " + t + " -o " + d.file(std::string("a") + t + ".h5"));
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

}  // namespace
