// The XML layer of the Mitsuba 0.5/0.6 scene reader (formats/scene_xml.h is its public face).
//
// The document is parsed with pugixml; each plugin element (<bsdf>, <shape>, ...) is read into a
// Plugin: its typed parameters (<float name=...>, <rgb>, <transform>, ...) and its nested plugin
// elements. The builder of each plugin kind (formats/mitsuba/builder.h) then *queries* the
// parameters it knows, with Mitsuba's defaults. Whatever was not queried is a warning naming file,
// line, plugin and parameter, as Mitsuba's "Unqueried attribute" (a misspelt parameter must not
// silently change a picture), and an error with SceneLoadOptions::strict; a documented list per plugin
// of parameters that have no effect in iris warns in either mode (finish()).
//
// Values are read lazily: "$name" substitution and number parsing happen when a parameter is
// queried, so an ignored parameter (e.g. an ldrfilm label full of "$scene['renderTime']") is never
// interpreted. Every message is "FILE:LINE: message"; lines come from pugixml's node offsets.
//
// Nothing here knows what a BSDF or a shape is: this layer reads documents, <include>s, $parameters
// and <default>s, ids, the typed values of a plugin element, and keeps the unqueried-parameter
// bookkeeping and the warnings.
#pragma once

#include <pugixml.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "formats/scene_xml.h"
#include "libcommon/scene.h"

namespace iris::mitsuba {

namespace fs = std::filesystem;

// ------------------------------------------------------------------------------------------------
// Fingerprint: two independent 64-bit hashes over a stream of length-prefixed byte strings (the
// scene file, each mesh file, the parameter overrides). 128 bits, so that stage files made for
// another scene are refused; not a cryptographic hash.
class Fingerprint {
public:
    void add(std::string_view bytes) {
        uint64_t n = bytes.size();
        unsigned char len[8];
        for (int i = 0; i < 8; ++i) len[i] = static_cast<unsigned char>(n >> (8 * i));
        feed(len, 8);
        feed(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
    }

    std::string hex() const {
        // Final avalanche for the second hash (the MurmurHash3 64-bit finaliser constants).
        uint64_t b = b_ ^ count_;
        b ^= b >> 33;
        b *= 0xff51afd7ed558ccdULL;
        b ^= b >> 33;
        b *= 0xc4ceb9fe1a85ec53ULL;
        b ^= b >> 33;
        char buf[33];
        std::snprintf(buf, sizeof buf, "%016llx%016llx", static_cast<unsigned long long>(a_),
                      static_cast<unsigned long long>(b));
        return buf;
    }

private:
    void feed(const unsigned char* p, size_t n) {
        for (size_t i = 0; i < n; ++i) {
            a_ = (a_ ^ p[i]) * 0x100000001b3ULL;  // FNV-1a, 64-bit prime
            // Second, unrelated stream: odd-constant multiply with an xor-shift per byte.
            b_ = (b_ ^ (p[i] + 0x9dULL)) * 0x9e3779b97f4a7c15ULL;
            b_ ^= b_ >> 29;
        }
        count_ += n;
    }

    uint64_t a_ = 0xcbf29ce484222325ULL;  // FNV-1a offset basis
    uint64_t b_ = 0x243f6a8885a308d3ULL;  // digits of pi: any seed unrelated to FNV's
    uint64_t count_ = 0;
};

// ------------------------------------------------------------------------------------------------
// A scene (or included) file with its line table.
struct Source {
    std::string path;  // as given, for messages
    fs::path dir;      // relative paths inside are resolved against this
    std::string text;
    std::vector<size_t> line_starts;  // byte offset of each line's first character
    pugi::xml_document doc;

    int line_at(ptrdiff_t offset) const {
        if (offset < 0) return 0;
        auto it = std::upper_bound(line_starts.begin(), line_starts.end(), size_t(offset));
        return int(it - line_starts.begin());
    }
    int line_of(pugi::xml_node n) const { return line_at(n.offset_debug()); }
};

[[noreturn]] void fail(const Source& src, int line, const std::string& msg);
std::string quote(std::string_view s);  // "s", with the quotes
std::string lower(std::string s);
// Reads a whole file; false if it cannot be read.
bool read_file(const fs::path& p, std::string* out);
// Splits on commas and whitespace, dropping empty pieces ("1, 2 3" -> 1 2 3), as Mitsuba's tokenize.
std::vector<std::string_view> tokens(std::string_view s);

// ------------------------------------------------------------------------------------------------
// Parameters and plugins.
enum class Kind : uint8_t { Float, Integer, Boolean, String, Point, Vector, Rgb, Srgb, Spectrum, Blackbody, Transform };

// A typed parameter of a plugin element (<float name="x" value="1"/>), read lazily by the getters.
struct Prop {
    Kind kind;
    std::string name;
    pugi::xml_node node;
    int line = 0;
    bool used = false;  // queried by the plugin's builder (XmlReader::finish refuses the others)
};

// A plugin element (<bsdf type="diffuse" id="...">): its parameters and nested plugin elements.
struct Plugin {
    const Source* src = nullptr;
    pugi::xml_node node;
    int line = 0;
    std::string tag;   // element name, e.g. "bsdf"
    std::string type;  // plugin type, e.g. "diffuse"
    std::string id;
    std::vector<Prop> props;
    std::vector<pugi::xml_node> children;  // nested plugin elements (and <ref>), in document order

    std::string what() const { return tag + " " + quote(type); }
};

// Why a parameter a plugin does not query is nevertheless acceptable (nullptr: it is an error).
using IgnoreRule = std::function<const char*(const std::string& name)>;

// Where an id was declared, for "refers to a <shape>, not to a bsdf" and duplicate-id messages.
struct IdInfo {
    std::string tag, file;
    int line;
};

// ------------------------------------------------------------------------------------------------
// Reads documents and plugin elements and hands out their typed parameter values (xml.cpp; the
// value parsers are in values.cpp). The getters mark a parameter as used; finish() then rejects (or
// warns about) every parameter nobody queried.
class XmlReader {
public:
    explicit XmlReader(const SceneLoadOptions& options) : options_(options) {}

    // ---- files (xml.cpp) ----
    // Reads and parses a scene or included file and adds it to the fingerprint. `from`/`from_line`:
    // the <include> that names it (null for the scene itself); `resolved`: its path, if not `path`.
    const Source& open_source(const std::string& path, const Source* from, int from_line, const fs::path& resolved);
    // A file named inside `src`, relative to `src`'s folder unless absolute.
    fs::path resolve(const Source& src, const std::string& file) const;

    // ---- messages ----
    // One warning line "FILE:LINE: msg", to SceneLoadOptions::warnings or stderr.
    void warn(const Source& src, int line, const std::string& msg);
    void check_attrs(const Source& src, pugi::xml_node n, std::initializer_list<const char*> allowed);
    // Element children only; stray text is an error (Mitsuba's schema has no text content).
    void check_no_text(const Source& src, pugi::xml_node n);

    // ---- $parameters ----
    // The <default name= value=> children of a <scene> root (the first one of a name wins).
    void collect_defaults(const Source& src, pugi::xml_node root);
    // One <default> element (at the top or inside a plugin element, as Mitsuba's schema allows).
    void collect_default(const Source& src, pugi::xml_node c);
    // The caller's values (they override <default>s).
    void set_parameter(const std::string& name, const std::string& value) { params_[name] = value; }
    // Replaces every $identifier by its parameter value; an unknown one is an error.
    std::string substitute(const Source& src, int line, std::string_view raw) const;
    // An attribute, substituted; attr() fails when it is missing.
    std::optional<std::string> opt_attr(const Source& src, pugi::xml_node n, const char* name) const;
    std::string attr(const Source& src, pugi::xml_node n, const char* name) const;

    // ---- numbers (values.cpp) ----
    float parse_float(const Source& src, int line, std::string_view s, const std::string& what) const;
    int parse_int(const Source& src, int line, std::string_view s, const std::string& what) const;
    std::vector<float> parse_floats(const Source& src, int line, std::string_view s, const std::string& what) const;
    Vec3 parse_vec3(const Source& src, int line, std::string_view s, const std::string& what) const;

    // ---- plugin elements and ids (xml.cpp) ----
    // A plugin element's type, id, parameters and nested plugin elements; registers its id.
    Plugin read_plugin(const Source& src, pugi::xml_node n);
    // Records an id (ids are unique across all kinds, as in Mitsuba); a repeated one fails.
    void register_id(const Source& src, int line, const std::string& id, const std::string& tag);
    // Where `id` was declared, or null.
    const IdInfo* id_info(const std::string& id) const;
    // The parameter `name` of `p`, or null (does not mark it used).
    Prop* find(Plugin& p, const std::string& name);
    [[noreturn]] void wrong_kind(const Plugin& p, const Prop& prop, const char* expected);
    std::string what(const Plugin& p, const Prop& prop) const;  // "parameter "x" of bsdf "y""
    // The "value" attribute of a simple parameter, substituted.
    std::string value_of(const Plugin& p, const Prop& prop);

    // ---- typed values (values.cpp); each marks the parameter used ----
    std::optional<float> get_float(Plugin& p, const std::string& name);  // <float> or <integer>
    float get_float(Plugin& p, const std::string& name, float def);
    std::optional<int> get_int(Plugin& p, const std::string& name);
    int get_int(Plugin& p, const std::string& name, int def);
    bool get_bool(Plugin& p, const std::string& name, bool def);
    std::optional<std::string> get_string(Plugin& p, const std::string& name);
    std::string get_string(Plugin& p, const std::string& name, const std::string& def);
    std::optional<Vec3> get_point(Plugin& p, const std::string& name);  // <point> or <vector>
    // <spectrum> (a value, nm:value pairs or an .spd file), <rgb>, <srgb> or <blackbody> -> linear RGB
    // (Mitsuba 0.5 RGB mode; see scenes/thesis/README.md).
    std::optional<RGB> get_spectrum(Plugin& p, const std::string& name);
    RGB get_spectrum(Plugin& p, const std::string& name, RGB def);
    // A refractive index given as a number or as one of Mitsuba's material names (`def`: a name).
    float get_ior(Plugin& p, const std::string& name, const char* def);
    std::optional<Transform> get_transform(Plugin& p, const std::string& name);
    // <transform>: the operations apply in the order listed, M = T_n ... T_1.
    Transform parse_transform(const Source& src, pugi::xml_node n);

    // ---- bookkeeping (xml.cpp) ----
    // Every parameter must have been queried, or be one the plugin accepts without using it
    // (`ignore` says why; it warns then).
    void finish(Plugin& p, const IgnoreRule& ignore = {});
    // Fails if the plugin has nested plugin elements.
    void no_children(const Plugin& p);

    // The scene's identity: every file read goes into it (scene files here; meshes and images in
    // the builders).
    Fingerprint fingerprint;
    // A spectrum that spectrum-interpolation changes was read (tabulated, from a file, a black body):
    // the setting is then part of the scene's identity (SceneBuilder::run).
    bool interpolated_spectrum = false;

protected:
    const SceneLoadOptions& options_;

private:
    std::map<std::string, std::string> params_;
    std::vector<std::unique_ptr<Source>> sources_;  // owned here: Plugins point into them
    std::map<std::string, IdInfo> ids_;
};

}  // namespace iris::mitsuba
