#include "tools/common/settings.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace iris {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
using K = SettingRow::Kind;
constexpr unsigned kPhotonsAndCaches = kTracePhotons | kPlaceCaches;

// The defaults are what pipelines/guided.mk used to set, i.e. what the benchmarks recommend
// (docs/BENCHMARKS.md says why for each; the comments of the options structs repeat it).
const std::vector<SettingRow> kTable = {
    // trace-photons
    {K::Integer, "photon-count", kTracePhotons, "500000", {}, 1, 1e12, false, false, "photons",
     "About this many photons are stored: the paths to emit are measured on the first 32768 (at most 2^26 paths)"},
    {K::Integer, "photon-paths", kTracePhotons, "0", {}, 0, 1e12, false, false, "paths",
     "Emit exactly this many photon paths instead (0 = as many as photon-count asks; --path-range needs it)"},
    {K::Integer, "photon-depth", kTracePhotons, "30", {"-1"}, 1, 1e9, false, false, "segments",
     "Longest photon path (light -> first hit = 1), -1 = unlimited"},
    {K::Integer, "photon-rr-depth", kTracePhotons, "3", {}, 1, 1e9, false, false, "bounces",
     "Russian roulette of photon paths from this many bounces on"},
    {K::Number, "photon-cutoff", kTracePhotons, "0.0001", {}, 0, 1, false, true, "fraction of a path's emitted power",
     "Stop a photon path whose power fell below this"},
    {K::Number, "min-caustic-share", kPhotonsAndCaches, "0.005", {}, 0, 1, false, false, "fraction of the photon power",
     "Below this share of light through specular chains no caches are placed (unguided render); 0 = always guide"},
    // every stage that loads the scene
    {K::Word, "spectrum-interpolation", kTracePhotons | kPlaceCaches | kRender, "linear", {"linear", "mitsuba-0.5.0"},
     0, 0, false, false, "-",
     "How a scene's tabulated spectra (nm:value pairs, .spd files; black bodies through the CIE tables) are "
     "interpolated between samples: linear (Mitsuba 0.6's core) or mitsuba-0.5.0 (that release's backwards "
     "interpolation, with which the thesis scenes were rendered)"},
    // place-caches
    {K::Integer, "cache-count", kPlaceCaches, "4000", {}, 1, 4294967295.0, false, false, "caches",
     "Caches in total, camera caches included"},
    {K::Integer, "camera-stride", kPlaceCaches, "8", {}, 0, 1e9, false, false, "pixels",
     "One camera cache per NxN pixel block of the image (0 = none)"},
    {K::Integer, "reach-paths", kPlaceCaches, "0", {}, 0, 1e9, false, false, "camera paths per pixel block",
     "Only photons on surfaces these camera paths reach become caches (0 = every photon is a candidate)"},
    // fill-caches
    {K::Integer, "gather-count", kFillCaches, "1000", {}, 1, 4294967295.0, false, false, "photons",
     "Photons gathered per cache (k nearest)"},
    {K::Integer, "map-resolution", kFillCaches, "32", {}, 1, 256, false, false, "texels (R x R over the sphere)",
     "Resolution R of each cache's directional map"},
    {K::Number, "filter-sigma", kFillCaches, "0.75", {}, 0, kInfinity, false, false, "texels",
     "Gaussian filter width of the maps (0 = none)"},
    {K::Number, "floor", kFillCaches, "0.1", {}, 0, 1, true, false, "fraction",
     "Weight of the uniform density mixed into every map"},
    {K::Number, "max-radius", kFillCaches, "0.05", {}, 0, kInfinity, true, false, "fraction of the scene's diagonal",
     "Gather radius limit"},
    {K::Integer, "min-photons", kFillCaches, "32", {}, 0, 4294967295.0, false, false, "photons",
     "A cache with fewer photons than this is not used"},
    {K::Word, "direct-photons", kFillCaches, "off", {"on", "off"}, 0, 0, false, false, "-",
     "Also count photons straight from the lights (for renders without NEE: mode=bsdf+cache)"},
    // render
    {K::Word, "pilot", kRender, "on", {"on", "off"}, 0, 0, false, false, "-",
     "With --atlas: a short pilot measures unguided and guided sampling and decides every `auto` (its time counts in --time)"},
    {K::Word, "mode", kRender, "nee+bsdf+cache", {"nee+bsdf", "nee+cache", "bsdf+cache", "nee+bsdf+cache"}, 0, 0, false,
     false, "-",
     "Sampling techniques combined by MIS where a cache guides; nee+bsdf = unguided (also without --atlas)"},
    {K::Integer, "guide-vertices", kRender, "auto", {"auto"}, 0, 1e9, false, false, "vertices",
     "Guide the first N non-specular vertices, 0 = all; auto: the pilot weighs 1 and all (unless rr-depth or "
     "rr-threshold is set), no pilot: 1"},
    {K::Number, "rr-threshold", kRender, "auto", {"auto"}, 0, 1, true, false, "throughput",
     "Russian roulette below this throughput; auto: 0.3, the pilot's every-vertex candidate 0.1"},
    {K::Integer, "rr-depth", kRender, "scene", {"scene"}, -1, 1e9, false, false, "bounces",
     "Russian roulette from this depth on, -1 = none (default: the scene's integrator rrDepth)"},
    {K::Integer, "max-depth", kRender, "scene", {"scene"}, -1, 1e9, false, false, "edges",
     "Longest path, -1 = unlimited (default: the scene's integrator maxDepth)"},
    {K::Number, "bsdf-fraction", kRender, "auto", {"auto"}, 0, 1, false, true, "probability",
     "BSDF sampling's share where a cache guides; auto: per cache from its distribution"},
    {K::Number, "min-gain", kRender, "1.25", {}, 1, kInfinity, false, false, "variance ratio",
     "With bsdf-fraction=auto: a cache predicted to gain less than this is not used"},
    {K::Word, "product", kRender, "on", {"on", "off"}, 0, 0, false, false, "-",
     "Where a cache guides a glossy lobe: sample the map's product with the lobe (off: the map alone)"},
    {K::Word, "caustics", kRender, "auto", {"auto", "on", "off"}, 0, 0, false, false, "-",
     "Light-trace caustics seen directly by the camera; auto: as the pilot decides, no pilot: off"},
    {K::Number, "light-paths", kRender, "auto", {"auto"}, 0, 1024, true, false, "light paths per pixel and pass",
     "With caustics: the light tracer's paths; auto: the pilot's choice, no pilot: 1"},
    {K::Word, "connect", kRender, "auto", {"auto", "on", "off"}, 0, 0, false, false, "-",
     "Caustic connections (camera vertices join light paths behind specular chains); auto: as the pilot decides, "
     "no pilot: off"},
    {K::Word, "sampler", kRender, "sobol", {"sobol", "independent"}, 0, 0, false, false, "-",
     "A pixel's samples: sobol (stratified pixel position and first bounce) or independent"},
    {K::Word, "learn", kRender, "off", {"on", "off"}, 0, 0, false, false, "-",
     "With --atlas: hybrid caches, refit from photons plus the render's paths after 1, 2, 4, ... spp"},
    {K::Word, "samples-layer", kRender, "off", {"on", "off"}, 0, 0, false, false, "-",
     "Add a layer 'samples' with the samples per pixel"},
};

std::string number_text(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.15g", v);
    return buf;
}

// Whether `s` is a whole finite number (an integer where `integer`), into *out.
bool parse_number(const std::string& s, bool integer, double* out) {
    if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return false;
    char* end = nullptr;
    errno = 0;
    if (integer) {
        const long long v = std::strtoll(s.c_str(), &end, 10);
        if (errno || end != s.c_str() + s.size()) return false;
        *out = double(v);
        return true;
    }
    const double v = std::strtod(s.c_str(), &end);
    if (errno || end != s.c_str() + s.size() || !std::isfinite(v)) return false;
    *out = v;
    return true;
}

// A Word setting's value as its place in the row's list of words (for the HDF5 provenance, which holds
// numbers), or -1.
int word_index(const SettingRow& row, const std::string& value) {
    if (row.kind != K::Word) return -1;
    for (size_t i = 0; i < row.words.size(); ++i)
        if (value == row.words[i]) return int(i);
    return -1;
}

}  // namespace

const std::vector<SettingRow>& settings_table() { return kTable; }

std::string stage_names(unsigned stages) {
    std::string out;
    const std::pair<unsigned, const char*> names[] = {
        {kTracePhotons, "trace-photons"}, {kPlaceCaches, "place-caches"}, {kFillCaches, "fill-caches"}, {kRender, "render"}};
    for (const auto& [bit, name] : names)
        if (stages & bit) out += (out.empty() ? "" : ", ") + std::string(name);
    return out;
}

std::string type_text(const SettingRow& row) {
    std::string out;
    // Words joined by " or " (a "|" would split the Markdown table's cell).
    for (size_t i = 0; i < row.words.size(); ++i)
        out += (i == 0 ? "" : i + 1 == row.words.size() && row.kind == K::Word ? " or " : ", ") + std::string(row.words[i]);
    if (row.kind == K::Word) return out;
    std::string t = row.kind == K::Integer ? "integer" : "number";
    // Upper limits of 1e9 and more only guard the integer types; not shown.
    const bool has_lo = row.lo > -kInfinity, has_hi = row.hi < 1e9;
    if (has_lo && has_hi)
        t += std::string(" in ") + (row.lo_open ? "(" : "[") + number_text(row.lo) + ", " + number_text(row.hi) +
             (row.hi_open ? ")" : "]");
    else if (has_lo)
        t += std::string(row.lo_open ? " > " : " >= ") + number_text(row.lo);
    return out.empty() ? t : out + " or " + t;
}

Settings::Settings(StageBit stage, const char* tool) : stage_(stage), tool_(tool) {
    for (const SettingRow& r : kTable)
        if (r.stages & stage) values_[r.name] = r.default_value;
}

const SettingRow& Settings::row(const std::string& name) const {
    for (const SettingRow& r : kTable)
        if (name == r.name) {
            if (!(r.stages & stage_))
                throw std::runtime_error("setting \"" + name + "\" is read by " + stage_names(r.stages) + ", not " + tool_ +
                                         " (see --list-settings)");
            return r;
        }
    throw std::runtime_error("unknown setting \"" + name + "\" (see --list-settings)");
}

void Settings::set(const std::string& assignment) {
    const size_t eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0)
        throw std::runtime_error("--set expects name=value, got \"" + assignment + "\" (see --list-settings)");
    const std::string name = assignment.substr(0, eq), value = assignment.substr(eq + 1);
    const SettingRow& r = row(name);
    bool ok = false;
    for (const char* w : r.words) ok = ok || value == w;
    double v = 0;
    if (!ok && r.kind != K::Word && parse_number(value, r.kind == K::Integer, &v))
        ok = (r.lo_open ? v > r.lo : v >= r.lo) && (r.hi_open ? v < r.hi : v <= r.hi);
    if (!ok)
        throw std::runtime_error("setting \"" + name + "\" must be " + type_text(r) + ", got \"" + value +
                                 "\" (see --list-settings)");
    values_[name] = value;
    given_[name] = true;
}

void Settings::set_all(const std::vector<std::string>& assignments) {
    for (const std::string& a : assignments) set(a);
}

const std::string& Settings::text(const std::string& name) const {
    auto it = values_.find(name);
    if (it == values_.end()) throw std::logic_error(tool_ + ": no setting \"" + name + "\" in this stage");
    return it->second;
}

long long Settings::integer(const std::string& name) const {
    double v = 0;
    if (!parse_number(text(name), true, &v)) throw std::logic_error("setting \"" + name + "\" is not an integer here");
    return (long long)v;
}

double Settings::number(const std::string& name) const {
    double v = 0;
    if (!parse_number(text(name), false, &v)) throw std::logic_error("setting \"" + name + "\" is not a number here");
    return v;
}

void Settings::resolve(const std::string& name, const std::string& value) {
    text(name);  // must exist
    values_[name] = value;
}

std::string Settings::record() const {
    std::string out;
    for (const SettingRow& r : kTable)
        if (r.stages & stage_) out += (out.empty() ? "" : "; ") + std::string(r.name) + "=" + values_.at(r.name);
    return out;
}

void Settings::add_to_parameters(std::map<std::string, double>* parameters) const {
    for (const auto& [name, value] : values_) {
        double v = 0;
        if (value == "on" || value == "off") v = value == "on" ? 1 : 0;
        else if (const int w = word_index(row(name), value); w >= 0) v = w;  // another word: its place in the row
        else if (!parse_number(value, false, &v)) throw std::logic_error("setting \"" + name + "\" is not a number");
        (*parameters)["setting:" + name] = v;
    }
}

std::map<std::string, std::string> Settings::parse_record(const std::string& record) {
    std::map<std::string, std::string> out;
    size_t from = 0;
    while (from < record.size()) {
        size_t to = record.find("; ", from);
        if (to == std::string::npos) to = record.size();
        const std::string item = record.substr(from, to - from);
        const size_t eq = item.find('=');
        if (eq != std::string::npos) out[item.substr(0, eq)] = item.substr(eq + 1);
        from = to + 2;
    }
    return out;
}

std::string Settings::markdown() const {
    std::string out = "| setting | stage | type | default | unit | meaning |\n|---|---|---|---|---|---|\n";
    for (const SettingRow& r : kTable)
        if (r.stages & stage_)
            out += "| " + std::string(r.name) + " | " + stage_names(r.stages) + " | " + type_text(r) + " | " +
                   r.default_value + " | " + r.unit + " | " + r.meaning + " |\n";
    return out;
}

void add_settings_options(CLI::App& app, StageBit stage, const char* tool, std::vector<std::string>* assignments) {
    app.add_option("--set", *assignments, "A named setting NAME=VALUE (repeatable; --list-settings shows them all)")
        ->type_name("NAME=VALUE")
        ->allow_extra_args(false);
    std::string name = tool;
    app.add_flag_callback(
        "--list-settings",
        [stage, name] {
            std::fputs(Settings(stage, name.c_str()).markdown().c_str(), stdout);
            throw CLI::Success();
        },
        "Print this tool's settings (name, type, default, unit, meaning) as a Markdown table and exit");
}

std::string settings_difference(const std::string& reference, const std::string& record) {
    const auto a = Settings::parse_record(reference), b = Settings::parse_record(record);
    for (const auto& [name, value] : a) {
        auto it = b.find(name);
        if (it == b.end()) return name + " missing, not " + name + "=" + value;
        if (it->second != value) return name + "=" + it->second + ", not " + name + "=" + value;
    }
    for (const auto& [name, value] : b)
        if (!a.count(name)) return name + "=" + value + " given, not in the other";
    return "";
}

}  // namespace iris
