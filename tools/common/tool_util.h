// Small helpers every command-line tool shares: the command line as text (for provenance) and an
// early check that the output can be written (before minutes of work, not after).
#pragma once

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace iris {

inline std::string join_args(int argc, char** argv) {
    std::string s;
    for (int i = 0; i < argc; ++i) {
        if (i) s += ' ';
        s += argv[i];
    }
    return s;
}

// Throws if `path`'s directory is missing or not writable, or `path` is a directory.
inline void check_output_path(const std::string& path) {
    namespace fs = std::filesystem;
    if (path.empty()) throw std::runtime_error("no output path given");
    fs::path dir = fs::path(path).parent_path();
    if (dir.empty()) dir = ".";
    if (!fs::is_directory(dir)) throw std::runtime_error(path + ": output directory does not exist");
    if (access(dir.c_str(), W_OK) != 0) throw std::runtime_error(path + ": output directory is not writable");
    if (fs::is_directory(path)) throw std::runtime_error(path + ": output path is a directory");
}

// Parses the command line. Returns -1 to go on, else the exit code: 0 after --help/--version, and
// non-zero after a bad flag, reported like every other error as one line "tool: error: ..." (DESIGN 3).
inline int parse_command_line(CLI::App& app, int argc, char** argv, const char* tool) {
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "%s: error: %s (see --help)\n", tool, e.what());
        return e.get_exit_code() != 0 ? e.get_exit_code() : 1;
    }
    return -1;
}

// "WxH" with positive integers, e.g. a --resolution value; throws otherwise.
inline void parse_resolution(const std::string& s, int* width, int* height) {
    char tail = 0;
    if (std::sscanf(s.c_str(), "%dx%d%c", width, height, &tail) != 2 || *width <= 0 || *height <= 0)
        throw std::runtime_error("--resolution must be WxH with positive integers, got \"" + s + "\"");
}

// A whole string as a finite float (for options that also take a word, like a setting that also takes auto);
// throws naming the option otherwise.
inline float parse_float_option(const char* option, const std::string& s) {
    char* end = nullptr;
    const float v = std::strtof(s.c_str(), &end);
    if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v))
        throw std::runtime_error(std::string(option) + " expects a number, got \"" + s + "\"");
    return v;
}

// "A:B" with integers 0 <= A < B (trace-photons' --path-range, render's --sample-range, the parts
// merge-photons and merge-images join); false for anything else, a sign included.
inline bool parse_range(const std::string& s, uint64_t* a, uint64_t* b) {
    unsigned long long x = 0, y = 0;
    char tail = 0;
    if (s.find('-') != std::string::npos || std::sscanf(s.c_str(), "%llu:%llu%c", &x, &y, &tail) != 2 || !(x < y))
        return false;
    *a = x;
    *b = y;
    return true;
}

// --strict: a parameter no plugin reads is an error (SceneLoadOptions::strict), for every tool that
// loads a scene.
inline void add_strict_option(CLI::App& app, bool* strict) {
    app.add_flag("--strict", *strict,
                 "A scene parameter that its plugin does not read is an error, not a warning (Mitsuba warns: "
                 "\"Unqueried attribute\")");
}

// --spectrum-interpolation for the tools that load a scene outside the stages (export-scene,
// inspect-caches), which have no settings table: the same words as the setting of that name.
inline void add_spectrum_interpolation_option(CLI::App& app, std::string* value) {
    app.add_option("--spectrum-interpolation", *value,
                   "linear (default) or mitsuba-0.5.0: how tabulated spectra are interpolated, as the stages' "
                   "setting spectrum-interpolation")
        ->check(CLI::IsMember({"linear", "mitsuba-0.5.0"}));
}

// The options of every stage tool that reads a scene: -D name=value (for $name in the scene file),
// --no-scene-warnings and --strict.
inline void add_scene_options(CLI::App& app, std::vector<std::string>* defines, bool* no_scene_warnings,
                              bool* strict) {
    app.add_option("-D,--define", *defines, "Scene parameter name=value (for $name in the scene file)");
    app.add_flag("--no-scene-warnings", *no_scene_warnings,
                 "Do not print the scene's warnings (ignored parameters); pipelines/guided.mk passes it to the "
                 "stages after trace-photons, which prints them once");
    add_strict_option(app, strict);
}

// "-D name=value" options into a parameter map (for $name in scene files).
inline std::map<std::string, std::string> parse_defines(const std::vector<std::string>& defines) {
    std::map<std::string, std::string> out;
    for (const std::string& d : defines) {
        auto eq = d.find('=');
        if (eq == std::string::npos || eq == 0) throw std::runtime_error("-D expects name=value, got \"" + d + "\"");
        out[d.substr(0, eq)] = d.substr(eq + 1);
    }
    return out;
}

}  // namespace iris
