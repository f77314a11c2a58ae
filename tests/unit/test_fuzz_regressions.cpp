// Every input the fuzzers found a problem with (tests/data/fuzz-regressions/<target>/, see
// scripts/fuzz.sh and docs/ROBUSTNESS-fuzzing.md) and the curated seeds (tests/fuzz/seeds/<target>/)
// go through the same harness the libFuzzer targets use (tests/fuzz/harness.h): the reader must
// either accept the input or throw its documented error type. Any other exception fails the test;
// in a sanitizer build (IRIS_SANITIZE=ON) memory errors and undefined behaviour abort it.
//
// Only the files directly in each folder are run. Subfolders hold inputs that are kept for the record
// but cannot be run (hdf5/libhdf5-crashes/: files that crash inside the HDF5 library itself; their
// README says where and in which HDF5 version).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz/harness.h"

namespace fs = std::filesystem;

namespace {

using OneInput = int (*)(const uint8_t*, size_t);

std::vector<fs::path> inputs_in(const fs::path& dir) {
    std::vector<fs::path> files;
    if (!fs::is_directory(dir)) return files;
    for (const fs::directory_entry& e : fs::directory_iterator(dir))
        if (e.is_regular_file() && e.path().filename().string().rfind("README", 0) != 0) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

std::string read_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs every input for `target`; returns how many there were.
size_t run_inputs(const std::string& target, OneInput one) {
    const fs::path root = IRIS_SOURCE_DIR;
    size_t n = 0;
    for (const fs::path& dir : {root / "tests/data/fuzz-regressions" / target, root / "tests/fuzz/seeds" / target})
        for (const fs::path& file : inputs_in(dir)) {
            SCOPED_TRACE(file.string());
            const std::string bytes = read_bytes(file);
            EXPECT_NO_THROW(one(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()));
            ++n;
        }
    return n;
}

}  // namespace

TEST(FuzzRegressions, SceneXml) { EXPECT_GT(run_inputs("scene_xml", iris::fuzz::scene_xml_one), 0u); }

TEST(FuzzRegressions, Obj) { EXPECT_GT(run_inputs("obj", iris::fuzz::obj_one), 0u); }

TEST(FuzzRegressions, Mesh) { EXPECT_GT(run_inputs("mesh", iris::fuzz::mesh_one), 0u); }

TEST(FuzzRegressions, StageHdf5) { EXPECT_GT(run_inputs("hdf5", iris::fuzz::stage_hdf5_one), 0u); }

// The harness itself: a valid input is read without an exception, an invalid one is swallowed, and
// the empty input is harmless for every target.
TEST(FuzzRegressions, HarnessAcceptsValidAndInvalidInputs) {
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    EXPECT_NO_THROW(iris::fuzz::obj_one(reinterpret_cast<const uint8_t*>(obj.data()), obj.size()));
    const std::string bad_obj = "f 1 2 3\n";
    EXPECT_NO_THROW(iris::fuzz::obj_one(reinterpret_cast<const uint8_t*>(bad_obj.data()), bad_obj.size()));
    const std::string scene =
        "<scene version=\"0.5.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" "
        "value=\"8\"/><integer name=\"height\" value=\"8\"/></film></sensor><shape type=\"obj\"><string "
        "name=\"filename\" value=\"mesh.obj\"/><emitter type=\"area\"/></shape><include "
        "filename=\"include.xml\"/></scene>";
    EXPECT_NO_THROW(iris::fuzz::scene_xml_one(reinterpret_cast<const uint8_t*>(scene.data()), scene.size()));
    for (OneInput one : {iris::fuzz::scene_xml_one, iris::fuzz::obj_one, iris::fuzz::mesh_one, iris::fuzz::stage_hdf5_one}) {
        EXPECT_NO_THROW(one(nullptr, 0));
        const uint8_t junk[] = {6, 'n', 'o', 't', ' ', 'h', 'd', 'f', '5'};
        EXPECT_NO_THROW(one(junk, sizeof junk));
    }
}
