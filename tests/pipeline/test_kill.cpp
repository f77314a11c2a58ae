// Kill tests: every stage killed with SIGKILL -- while it computes, and at the worst moment, with its
// output complete in the temporary file but not yet renamed -- leaves nothing under the final name
// (or the previous file there, untouched), and a rerun succeeds and clears the dead run's temporary
// file. A render writing progressive snapshots leaves a usable image when killed.
//
// The worst moment is reached without racing the process: IRIS_TEST_COMMIT_DELAY_MS makes the writer
// wait just before the rename (formats/atomic_file.cpp).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "formats/exr.h"
#include "support/run_tool.h"

namespace fs = std::filesystem;
using namespace iris::test;

namespace {

// A tool started in the background (through `sh -c exec ...`, so the pid is the tool's own).
class Background {
public:
    explicit Background(const std::string& command) {
        pid_ = ::fork();
        if (pid_ == 0) {
            const std::string cmd = "exec " + command + " >/dev/null 2>&1";
            ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
            ::_exit(127);
        }
    }
    ~Background() {
        if (pid_ > 0 && !reaped_) {
            ::kill(pid_, SIGKILL);
            ::waitpid(pid_, nullptr, 0);
        }
    }
    // Still running (not exited)?
    bool running() {
        if (reaped_) return false;
        int st;
        if (::waitpid(pid_, &st, WNOHANG) == pid_) {
            reaped_ = true;
            status_ = st;
        }
        return !reaped_;
    }
    // SIGKILL and wait; returns true if the process was still running when killed.
    bool kill_now() {
        if (!running()) return false;
        ::kill(pid_, SIGKILL);
        int st;
        ::waitpid(pid_, &st, 0);
        reaped_ = true;
        status_ = st;
        return WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL;
    }
    int pid() const { return pid_; }

private:
    pid_t pid_ = -1;
    bool reaped_ = false;
    int status_ = 0;
};

// Polls `done` every 5 ms for up to `seconds`.
template <class F>
bool wait_for(F done, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
        if (done()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return done();
}

std::string read_bytes(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
}

struct Stage {
    const char* name;
    // Arguments before -o: `slow` runs for many seconds, `quick` for a fraction of one.
    std::string slow, quick;
    const char* ext;
};

class KillTest : public ::testing::TestWithParam<int> {
protected:
    static void SetUpTestSuite() {
        dir_ = new TempDir;
        const std::string scene = data_file("guiding/caustic_box.xml");
        auto run = [](const std::string& cmd) {
            ToolResult r = run_command(cmd);
            ASSERT_EQ(r.status, 0) << cmd << "\n" << r.output;
        };
        run(tool("trace-photons") + " " + scene + " -q --set photon-paths=3000 -o " + dir_->file("photons.h5"));
        run(tool("place-caches") + " " + scene + " --photon-map " + dir_->file("photons.h5") + " -q --set cache-count=40 -o " +
            dir_->file("caches.h5"));
    }
    // Inputs big enough that place-caches and fill-caches run for seconds (their cost grows with
    // photons x caches); made only by the tests that need them, as ctest runs each test on its own.
    static void make_big_inputs() {
        const std::string scene = data_file("guiding/caustic_box.xml");
        for (const std::string& cmd :
             {tool("trace-photons") + " " + scene + " -q --set photon-paths=100000 -o " + dir_->file("many_photons.h5"),
              tool("place-caches") + " " + scene + " --photon-map " + dir_->file("many_photons.h5") +
                  " -q --set cache-count=5000 -o " + dir_->file("many_caches.h5")}) {
            ToolResult r = run_command(cmd);
            ASSERT_EQ(r.status, 0) << cmd << "\n" << r.output;
        }
    }
    static void TearDownTestSuite() {
        delete dir_;
        dir_ = nullptr;
    }
    static Stage stage(int i) {
        const std::string scene = data_file("guiding/caustic_box.xml");
        const std::string photons = " --photon-map " + dir_->file("photons.h5");
        const Stage stages[] = {
            {"trace-photons", scene + " --set photon-paths=200000000", scene + " --set photon-paths=2000", ".h5"},
            {"place-caches", scene + " --photon-map " + dir_->file("many_photons.h5") + " --set cache-count=2000000",
             scene + photons + " --set cache-count=20", ".h5"},
            {"fill-caches", dir_->file("many_caches.h5") + " --photon-map " + dir_->file("many_photons.h5") +
                                " --set gather-count=2000 --set map-resolution=64",
             dir_->file("caches.h5") + photons + " --set gather-count=30 --set map-resolution=4", ".h5"},
            {"render", scene + " --spp 100000", scene + " --spp 2", ".exr"},
        };
        return stages[i];
    }
    static TempDir* dir_;
};
TempDir* KillTest::dir_ = nullptr;

// Killed while computing: no output, no temporary file; a rerun succeeds.
TEST_P(KillTest, KilledWhileComputingLeavesNothing) {
    if (GetParam() == 1 || GetParam() == 2) make_big_inputs();
    const Stage s = stage(GetParam());
    TempDir out_dir;
    const std::string out = out_dir.file(std::string("out") + s.ext);
    {
        Background p(tool(s.name) + " " + s.slow + " -q -o " + out);
        std::this_thread::sleep_for(std::chrono::milliseconds(700));
        ASSERT_TRUE(p.kill_now()) << s.name << " finished before it could be killed: make `slow` slower";
    }
    EXPECT_FALSE(fs::exists(out));
    EXPECT_TRUE(fs::is_empty(out_dir.path)) << "a killed run left a file behind";
    ToolResult r = run_command(tool(s.name) + " " + s.quick + " -q -o " + out);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(fs::exists(out));
}

// Killed with the complete output in its temporary file, just before the rename: the final name
// still holds the previous file, byte for byte. The dead run's temporary file is left (nothing can
// remove it at SIGKILL); the rerun removes it and puts its own complete output in place.
TEST_P(KillTest, KilledBeforeRenameKeepsThePreviousFile) {
    const Stage s = stage(GetParam());
    TempDir out_dir;
    const std::string out = out_dir.file(std::string("out") + s.ext);
    ToolResult first = run_command(tool(s.name) + " " + s.quick + " -q --seed 1 -o " + out);
    ASSERT_EQ(first.status, 0) << first.output;
    const std::string previous = read_bytes(out);
    std::string tmp;
    {
        Background p("env IRIS_TEST_COMMIT_DELAY_MS=60000 " + tool(s.name) + " " + s.quick + " -q --seed 2 -o " + out);
        tmp = out + ".tmp-" + std::to_string(p.pid());
        ASSERT_TRUE(wait_for([&] { return fs::exists(tmp); }, 60)) << "the temporary file " << tmp << " never appeared";
        // The quick run finishes writing well within a second, then waits (60 s) before the rename.
        std::this_thread::sleep_for(std::chrono::milliseconds(1000));
        ASSERT_TRUE(p.kill_now()) << s.name << " exited instead of waiting before the rename";
    }
    EXPECT_EQ(read_bytes(out), previous) << "the previous output was changed by a run that never finished";
    EXPECT_TRUE(fs::exists(tmp)) << "expected the dead run's temporary file";
    ToolResult r = run_command(tool(s.name) + " " + s.quick + " -q --seed 2 -o " + out);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(read_bytes(out), previous) << "the rerun (another seed) should have replaced the file";
    EXPECT_FALSE(fs::exists(tmp)) << "the rerun should remove the dead run's temporary file";
    EXPECT_EQ(std::distance(fs::directory_iterator(out_dir.path), fs::directory_iterator()), 1);
}

const char* const kStageNames[] = {"trace_photons", "place_caches", "fill_caches", "render"};  // (stage()'s order)
INSTANTIATE_TEST_SUITE_P(Stage, KillTest, ::testing::Range(0, 4),
                         [](const ::testing::TestParamInfo<int>& info) { return std::string(kStageNames[info.param]); });

// A render with --snapshot writes the image so far every interval; killed midway, it leaves a complete,
// readable image with fewer samples than asked for, and no NaN/Inf.
TEST(KillRender, SnapshotsLeaveAUsableImage) {
    TempDir out_dir;
    const std::string out = out_dir.file("out.exr");
    {
        Background p(tool("render") + " " + data_file("guiding/caustic_box.xml") + " --spp 1000000 --snapshot 0.2 -q -o " +
                     out);
        ASSERT_TRUE(wait_for([&] { return fs::exists(out); }, 60)) << "no snapshot was written";
        std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let a few more snapshots replace it
        ASSERT_TRUE(p.kill_now()) << "the render finished before it could be killed";
    }
    iris::Image img = iris::read_exr(out);  // throws if the file were incomplete
    const int spp = std::stoi(img.metadata.at("iris:spp"));
    EXPECT_GT(spp, 0);
    EXPECT_LT(spp, 1000000);
    EXPECT_EQ(img.metadata.at("iris:nonfinite_samples"), "0");
    double sum = 0;
    for (const auto& channel : img.data)
        for (float v : channel) {
            ASSERT_TRUE(std::isfinite(v));
            sum += v;
        }
    EXPECT_GT(sum, 0) << "the snapshot is black";
}

}  // namespace
