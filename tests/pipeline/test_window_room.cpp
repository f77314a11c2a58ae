// scenes/window_room (issue 27): binary PLY meshes with uvs, textured diffuse surfaces and an envmap sun
// through a window go through the whole guided pipeline (pipelines/guided.mk compare) at tiny settings.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "support/run_tool.h"

namespace {

using iris::test::run_command;
using iris::test::TempDir;

TEST(WindowRoom, GuidedPipelineCompareRuns) {
    TempDir dir;
    const std::string src = IRIS_SOURCE_DIR;
    // QUIET= keeps trace-photons' summary line, which names the photons stored.
    const auto r = run_command("make --no-print-directory -f " + src + "/pipelines/guided.mk BIN=" +
                               std::string(IRIS_BIN_DIR) + " SCENE=" + src + "/scenes/window_room/window_room.xml" +
                               " OUT=" + dir.file("out") + " REF_DIR=" + dir.file("ref") +
                               " PHOTONS_SET='photon-paths=4000 min-caustic-share=0' CACHES_SET='cache-count=64 min-caustic-share=0'"
                               " ATLAS_SET=gather-count=64 SPP=2 REF_SPP=2 THREADS=2 QUIET= compare");
    ASSERT_EQ(r.status, 0) << r.output;
    // The scene uses nothing iris ignores: a warning would mean a parameter of it is dropped.
    EXPECT_EQ(r.output.find("warning: "), std::string::npos) << r.output;
    // Some envmap photons came in through the window (a few % of the paths: scenes/window_room/README.md).
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(trace-photons: wrote .* \((\d+) photons from 4000 paths)")))
        << r.output;
    EXPECT_GT(std::stoll(m[1].str()), 0) << r.output;
    for (const char* f : {"photons.h5", "caches.h5", "atlas.h5", "guided.exr", "unguided.exr", "comparison.txt"})
        EXPECT_TRUE(std::filesystem::exists(dir.file(std::string("out/") + f))) << f;
    std::ifstream in(dir.file("out/comparison.txt"));
    std::stringstream ss;
    ss << in.rdbuf();
    EXPECT_NE(ss.str().find("relMSE unguided / guided at equal total time"), std::string::npos) << ss.str();
}

}  // namespace
