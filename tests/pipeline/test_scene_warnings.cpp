// Scene warnings (parameters and elements iris accepts but ignores) are printed once per pipeline run:
// trace-photons prints them, and pipelines/guided.mk passes --no-scene-warnings to the stages after it,
// which read the same scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

#include "support/run_tool.h"

namespace {

using iris::test::run_command;
using iris::test::TempDir;
using iris::test::tool;

// The tiny caustic box with two elements that each draw one warning: a bsdf no shape references, and a
// top-level bsdf without an id.
std::string write_scene(const TempDir& dir) {
    std::ifstream in(std::string(IRIS_SOURCE_DIR) + "/tests/data/guiding/caustic_box.xml");
    std::stringstream ss;
    ss << in.rdbuf();
    std::string xml = ss.str();
    const std::string tag = "<scene version=\"0.5.0\">";
    const size_t at = xml.find(tag);
    EXPECT_NE(at, std::string::npos);
    xml.insert(at + tag.size(), "\n  <bsdf type=\"diffuse\" id=\"never_used\"/>\n  <bsdf type=\"diffuse\"/>\n");
    const std::string path = dir.file("scene.xml");
    std::ofstream(path) << xml;
    return path;
}

int count_lines_starting(const std::string& text, const std::string& prefix) {
    int n = 0;
    std::istringstream s(text);
    for (std::string line; std::getline(s, line);) n += line.rfind(prefix, 0) == 0 ? 1 : 0;
    return n;
}

TEST(SceneWarnings, ToolPrintsThemUnlessToldNot) {
    TempDir dir;
    const std::string scene = write_scene(dir);
    const auto loud = run_command(tool("render") + " " + scene + " -o " + dir.file("a.exr") + " --spp 1 -q");
    ASSERT_EQ(loud.status, 0) << loud.output;
    EXPECT_EQ(count_lines_starting(loud.output, "warning: "), 2) << loud.output;
    const auto quiet = run_command(tool("render") + " " + scene + " -o " + dir.file("b.exr") +
                                   " --spp 1 -q --no-scene-warnings");
    ASSERT_EQ(quiet.status, 0) << quiet.output;
    EXPECT_EQ(count_lines_starting(quiet.output, "warning: "), 0) << quiet.output;
}

// A parameter its plugin does not read (Mitsuba: "Unqueried attribute") is a warning naming file:line,
// plugin and parameter, and the scene renders; --strict makes it the one-line error it used to be, with
// no output.
TEST(SceneWarnings, UnreadParameterWarnsAndRendersStrictRefuses) {
    TempDir dir;
    std::ifstream in(std::string(IRIS_SOURCE_DIR) + "/tests/data/guiding/caustic_box.xml");
    std::stringstream ss;
    ss << in.rdbuf();
    std::string xml = ss.str();
    const std::string tag = "<scene version=\"0.5.0\">";
    const size_t at = xml.find(tag);
    ASSERT_NE(at, std::string::npos);
    xml.insert(at + tag.size(), "\n  <shape type=\"sphere\"><float name=\"radius\" value=\"0.01\"/>"
                                "<float name=\"radus\" value=\"0.5\"/></shape>\n");
    const int line = 1 + int(std::count(xml.begin(), xml.begin() + std::ptrdiff_t(xml.find("radus")), '\n'));
    const std::string scene = dir.file("scene.xml");
    std::ofstream(scene) << xml;
    const auto r = run_command(tool("render") + " " + scene + " -o " + dir.file("a.exr") + " --spp 1 -q");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("warning: " + scene + ":" + std::to_string(line) +
                            ": parameter \"radus\" of shape \"sphere\" is not read"),
              std::string::npos)
        << r.output;
    EXPECT_TRUE(std::ifstream(dir.file("a.exr")).good());
    const auto strict = run_command(tool("render") + " " + scene + " -o " + dir.file("b.exr") + " --spp 1 -q --strict");
    EXPECT_NE(strict.status, 0);
    EXPECT_EQ(count_lines_starting(strict.output, "render: error: " + scene + ":" + std::to_string(line) +
                                                      ": unknown parameter \"radus\""),
              1)
        << strict.output;
    EXPECT_EQ(std::count(strict.output.begin(), strict.output.end(), '\n'), 1) << strict.output;
    EXPECT_FALSE(std::ifstream(dir.file("b.exr")).good());
}

TEST(SceneWarnings, FullGuidedPipelinePrintsEachOnce) {
    TempDir dir;
    const std::string scene = write_scene(dir);
    // Every stage of `compare`: photons, caches, atlas, guided and unguided renders, the reference.
    const auto r = run_command("make --no-print-directory -f " + std::string(IRIS_SOURCE_DIR) +
                               "/pipelines/guided.mk BIN=" + std::string(IRIS_BIN_DIR) + " SCENE=" + scene +
                               " OUT=" + dir.file("out") + " REF_DIR=" + dir.file("ref") +
                               " PHOTONS_SET='photon-paths=2000 min-caustic-share=0' CACHES_SET='cache-count=64 min-caustic-share=0'"
                               " ATLAS_SET=gather-count=64 SPP=2 REF_SPP=4 THREADS=2 compare");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(count_lines_starting(r.output, "warning: "), 2) << r.output;
    EXPECT_NE(r.output.find("never_used"), std::string::npos) << r.output;
}

}  // namespace
