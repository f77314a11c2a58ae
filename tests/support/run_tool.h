// Running the built tools from tests: command line in, exit status and captured output back.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

#include "support/temp_dir.h"

namespace iris::test {

struct ToolResult {
    int status = -1;     // exit status (128 + signal if killed)
    std::string output;  // stdout and stderr together
};

// Runs `command` through the shell with stderr merged into stdout.
inline ToolResult run_command(const std::string& command) {
    ToolResult r;
    FILE* p = popen((command + " 2>&1").c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
    int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return r;
}

// Path of a built tool.
inline std::string tool(const std::string& name) { return std::string(IRIS_BIN_DIR) + "/" + name; }

// Path of a file under tests/data.
inline std::string data_file(const std::string& rel) { return std::string(IRIS_SOURCE_DIR) + "/tests/data/" + rel; }


}  // namespace iris::test

namespace iris::test::cli {
// The stage flags that the newer tests write, in one place: when the command line changes (named
// settings, `--set name=value`), adapt these and not the tests.
inline std::string set(const std::string& name, const std::string& value) { return "--set " + name + "=" + value; }
inline std::string photon_paths(long n) { return set("photon-paths", std::to_string(n)); }        // trace-photons
inline std::string photon_map(const std::string& f) { return "--photon-map " + f; }              // place-, fill-caches
inline std::string cache_count(int n) { return set("cache-count", std::to_string(n)); }           // place-caches
inline std::string gather_count(int k) { return set("gather-count", std::to_string(k)); }         // fill-caches
inline std::string map_resolution(int r) { return set("map-resolution", std::to_string(r)); }     // fill-caches
inline std::string direct_photons() { return set("direct-photons", "on"); }                      // fill-caches
inline std::string mode(const std::string& m) { return set("mode", m); }                         // render
inline std::string caustics(const std::string& v) { return set("caustics", v); }                 // render
inline std::string max_depth(int d) { return set("max-depth", std::to_string(d)); }              // render
}  // namespace iris::test::cli
