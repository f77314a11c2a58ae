// The settings of the four stage tools (tools/common/settings.h): --list-settings prints each tool's rows
// of the one table, --set refuses unknown names, another stage's settings and bad values in one line
// naming the setting (and writes nothing), and the outputs record the settings as they ran.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>

#include "formats/exr.h"
#include "formats/photon_map.h"
#include "support/run_tool.h"

namespace {

using namespace iris;
using namespace iris::test;

int count_lines(const std::string& s) {
    int n = 0;
    for (char c : s) n += c == '\n';
    return n;
}

TEST(SettingsCli, ListSettingsPrintsEachToolsRows) {
    const std::pair<const char*, const char*> tools[] = {{"trace-photons", "| photon-count | trace-photons | integer >= 1 | 500000 |"},
                                                         {"place-caches", "| cache-count | place-caches | integer >= 1 | 4000 |"},
                                                         {"fill-caches", "| gather-count | fill-caches | integer >= 1 | 1000 |"},
                                                         {"render", "| pilot | render | on or off | on |"}};
    for (const auto& [name, row] : tools) {
        SCOPED_TRACE(name);
        // No scene needed: the table is printed before the required arguments are checked.
        const ToolResult r = run_command(tool(name) + " --list-settings");
        ASSERT_EQ(r.status, 0) << r.output;
        EXPECT_EQ(r.output.rfind("| setting | stage | type | default | unit | meaning |\n|---|---|---|---|---|---|\n", 0), 0u)
            << r.output;
        EXPECT_NE(r.output.find(row), std::string::npos) << r.output;
        // Every line a row of six cells.
        std::istringstream in(r.output);
        std::string line;
        while (std::getline(in, line)) {
            int bars = 0;
            for (char c : line) bars += c == '|';
            EXPECT_EQ(bars, 7) << line;
        }
    }
    // The setting two stages read is listed by both.
    for (const char* name : {"trace-photons", "place-caches"})
        EXPECT_NE(run_command(tool(name) + " --list-settings").output.find("| min-caustic-share | trace-photons, place-caches |"),
                  std::string::npos);
    EXPECT_EQ(run_command(tool("render") + " --list-settings").output.find("photon-count"), std::string::npos);
}

// render --help lists only the everyday flags (PLAN's command line: 16 and --help, --version); every
// technique knob is a setting.
TEST(SettingsCli, RenderHelpListsTheEverydayFlagsOnly) {
    const ToolResult r = run_command(tool("render") + " --help");
    ASSERT_EQ(r.status, 0) << r.output;
    std::istringstream in(r.output.substr(r.output.find("Options:")));
    std::string line;
    int options = 0;
    while (std::getline(in, line)) options += line.rfind("  -", 0) == 0;
    EXPECT_LE(options, 19) << r.output;  // 19: --strict (scene loading, like -D and --no-scene-warnings)
    for (const char* gone : {"--mode", "--caustics", "--connect", "--guide-vertices", "--max-depth", "--learn"})
        EXPECT_EQ(r.output.find(std::string(gone) + " "), std::string::npos) << gone;
}

TEST(SettingsCli, BadSettingsAreOneLineErrorsNamingTheSetting) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    struct Case {
        const char* tool;
        std::string args, message;
    };
    const Case cases[] = {
        {"render", scene + " --set foo=1", "render: error: unknown setting \"foo\" (see --list-settings)"},
        {"render", scene + " --set photon-count=5",
         "render: error: setting \"photon-count\" is read by trace-photons, not render (see --list-settings)"},
        {"render", scene + " --set rr-threshold=2",
         "render: error: setting \"rr-threshold\" must be auto or number in (0, 1], got \"2\" (see --list-settings)"},
        {"render", scene + " --set caustics", "render: error: --set expects name=value, got \"caustics\""},
        {"render", scene + " --set sampler=halton", "setting \"sampler\" must be sobol or independent, got \"halton\""},
        {"trace-photons", scene + " --set photon-count=1.5", "setting \"photon-count\" must be integer >= 1"},
        {"trace-photons", scene + " --set gather-count=5", "is read by fill-caches, not trace-photons"},
        {"place-caches", scene + " --photon-map x.h5 --set cache-count=-1", "setting \"cache-count\" must be integer >= 1"},
        {"fill-caches", "c.h5 --photon-map p.h5 --set map-resolution=300", "setting \"map-resolution\" must be integer in [1, 256]"},
        {"fill-caches", "c.h5 --photon-map p.h5 --set direct-photons=yes", "setting \"direct-photons\" must be on or off"},
    };
    for (const Case& c : cases) {
        const std::string out = dir.file("out");
        const ToolResult r = run_command(tool(c.tool) + " " + c.args + " -q -o " + out);
        SCOPED_TRACE(std::string(c.tool) + " " + c.args);
        EXPECT_NE(r.status, 0);
        EXPECT_EQ(count_lines(r.output), 1) << r.output;
        EXPECT_NE(r.output.find(c.message), std::string::npos) << r.output;
        EXPECT_FALSE(std::filesystem::exists(out));
    }
}

TEST(SettingsCli, OutputsRecordTheSettings) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    ToolResult r = run_command(tool("render") + " " + scene + " -q --spp 1 --resolution 8x8 --set sampler=independent "
                               "--set rr-threshold=0.5 --set max-depth=4 -o " + dir.file("a.exr"));
    ASSERT_EQ(r.status, 0) << r.output;
    // Every render setting, in the table's order, max-depth as given and rr-depth resolved from the scene.
    EXPECT_EQ(read_exr(dir.file("a.exr")).metadata.at("iris:settings"),
              "spectrum-interpolation=linear; pilot=on; mode=nee+bsdf+cache; guide-vertices=auto; rr-threshold=0.5; "
              "rr-depth=5; max-depth=4; "
              "bsdf-fraction=auto; min-gain=1.25; product=on; caustics=auto; light-paths=auto; connect=auto; "
              "sampler=independent; learn=off; samples-layer=off");
    r = run_command(tool("trace-photons") + " " + scene + " -q --set photon-paths=500 --set photon-depth=5 -o " +
                    dir.file("p.h5"));
    ASSERT_EQ(r.status, 0) << r.output;
    const auto p = read_photon_map_header(dir.file("p.h5")).provenance.parameters;
    EXPECT_EQ(p.at("setting:photon-paths"), 500);
    EXPECT_EQ(p.at("setting:photon-depth"), 5);
    EXPECT_EQ(p.at("setting:photon-count"), 500000);  // the default, unused where photon-paths is set
    EXPECT_EQ(p.at("setting:min-caustic-share"), 0.005);
    EXPECT_EQ(p.at("setting:spectrum-interpolation"), 0);  // a word as its place in the row: linear
}

// merge-images names the setting in which two parts differ.
TEST(SettingsCli, MergeImagesNamesTheSettingThatDiffers) {
    TempDir dir;
    const std::string base = tool("render") + " " + data_file("guiding/caustic_box.xml") +
                             " -q --spp 4 --resolution 8x8 --seed 3";
    ASSERT_EQ(run_command(base + " --sample-range 0:2 -o " + dir.file("a.exr")).status, 0);
    ASSERT_EQ(run_command(base + " --sample-range 2:4 --set min-gain=2 -o " + dir.file("b.exr")).status, 0);
    const ToolResult r = run_command(tool("merge-images") + " " + dir.file("a.exr") + " " + dir.file("b.exr") + " -o " +
                                     dir.file("m.exr"));
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("rendered with other settings than " + dir.file("a.exr") + ": min-gain=2, not min-gain=1.25"),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir.file("m.exr")));
}

}  // namespace
