// The named settings of the four stage tools (trace-photons, place-caches, fill-caches, render): one
// table (name, type, default, unit, one-line meaning, the stages that read it), set with
// `--set name=value`, printed by `--list-settings`, and recorded in every output ("name=value; ...":
// the EXR attribute iris:settings, the HDF5 provenance parameters "setting:NAME"). The defaults are the
// recommended settings; the everyday options (output, threads, seed, budget, ...) stay flags.
#pragma once

#include <CLI/CLI.hpp>

#include <map>
#include <string>
#include <vector>

namespace iris {

// The stages, as bits (a setting can be read by several).
enum StageBit : unsigned { kTracePhotons = 1, kPlaceCaches = 2, kFillCaches = 4, kRender = 8 };

// One row of the table. A value is one of `words` (e.g. "auto", or the choices of a switch), or, for
// kind Integer / Number, a number in [lo, hi] (open ends where lo_open / hi_open).
struct SettingRow {
    enum class Kind { Integer, Number, Word } kind;
    const char* name;
    unsigned stages;
    const char* default_value;  // as the user would write it ("scene": the scene's integrator element)
    std::vector<const char*> words;
    double lo, hi;
    bool lo_open, hi_open;
    const char* unit;
    const char* meaning;
};

const std::vector<SettingRow>& settings_table();
// "trace-photons, place-caches" for a row's stage bits.
std::string stage_names(unsigned stages);
// The type column, e.g. "auto or number in (0, 1]".
std::string type_text(const SettingRow& row);

// The settings of one stage: defaults, then `--set` assignments in order (a later one wins).
class Settings {
public:
    Settings(StageBit stage, const char* tool);
    // "name=value". Throws std::runtime_error naming the setting: unknown name, another stage's
    // setting, a value outside its type.
    void set(const std::string& assignment);
    void set_all(const std::vector<std::string>& assignments);
    // The value as text, and typed (integer() / number() throw where the value is a word, e.g. "auto").
    const std::string& text(const std::string& name) const;
    bool is(const std::string& name, const char* word) const { return text(name) == word; }
    long long integer(const std::string& name) const;
    double number(const std::string& name) const;
    bool on(const std::string& name) const { return is(name, "on"); }
    // Whether --set named it (the value may still equal the default).
    bool given(const std::string& name) const { return given_.count(name) > 0; }
    // Replaces a default that depends on the input (render's max-depth / rr-depth: "scene") by the value
    // it resolved to, for the record.
    void resolve(const std::string& name, const std::string& value);
    // "name=value; name=value; ..." in table order: every setting of the stage, as it ran.
    std::string record() const;
    // The record as provenance parameters of an HDF5 stage file: "setting:NAME" -> value (on/off as
    // 1/0, another word as its place in the row's list: spectrum-interpolation linear 0, mitsuba-0.5.0 1).
    void add_to_parameters(std::map<std::string, double>* parameters) const;
    // name -> value, from a record.
    static std::map<std::string, std::string> parse_record(const std::string& record);
    // The stage's rows as a Markdown table (docs/GUIDE.md's settings section is generated from it).
    std::string markdown() const;

private:
    const SettingRow& row(const std::string& name) const;
    StageBit stage_;
    std::string tool_;
    std::map<std::string, std::string> values_;
    std::map<std::string, bool> given_;
};

// The options every stage tool has for its settings: --set NAME=VALUE (repeatable, into `assignments`)
// and --list-settings (prints the stage's table and exits 0, before required arguments are checked).
void add_settings_options(CLI::App& app, StageBit stage, const char* tool, std::vector<std::string>* assignments);

// merge's comparison of two records: "" where they agree, else the first setting that differs, as
// "name=a, not name=b" (`a` from `record`, `b` from `reference`).
std::string settings_difference(const std::string& reference, const std::string& record);

}  // namespace iris
