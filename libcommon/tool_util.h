// Small helpers every command-line tool shares: the command line as text (for provenance) and an
// early check that the output can be written (before minutes of work, not after).
#pragma once

#include <unistd.h>

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
