// Mitsuba 0.5/0.6 scene XML reader (the subset in DESIGN.md section 3), with OBJ meshes.
//
// Structure: the XML is parsed with pugixml into a DOM; each plugin element (<bsdf>, <shape>, ...)
// is read into a Plugin: its typed parameters (<float name=...> etc.) and its nested plugin elements.
// The code for each plugin type then *queries* the parameters it knows, with Mitsuba's defaults.
// Whatever was not queried is an error (a misspelt parameter must not silently change a picture),
// except for a documented list per plugin that has no effect in iris (or none in Mitsuba either),
// which is accepted with a warning.
//
// Values are read lazily: "$name" substitution and number parsing happen when a parameter is
// queried, so an ignored parameter (e.g. an ldrfilm label full of "$scene['renderTime']") is never
// interpreted. Every message is "FILE:LINE: message"; lines come from pugixml's node offsets.
#include "formats/scene_xml.h"

#include <pugixml.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_map>

#include "formats/exr.h"
#include "formats/image_file.h"
#include "formats/obj.h"
#include "formats/ply.h"
#include "formats/serialized.h"
#include "formats/texture_file.h"
#include "libcommon/spectrum.h"

namespace iris {
namespace {

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

[[noreturn]] void fail(const Source& src, int line, const std::string& msg) {
    throw SceneError(src.path + ":" + std::to_string(line) + ": " + msg);
}

std::string quote(std::string_view s) {
    std::string q;
    q.reserve(s.size() + 2);
    q.push_back('"');
    q.append(s);
    q.push_back('"');
    return q;
}

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool read_file(const fs::path& p, std::string* out) {
    std::ifstream in(p, std::ios::binary);
    if (!in) return false;
    // One read into a buffer of the file's size: mesh files reach hundreds of MB, and a
    // stringstream would copy them twice.
    std::error_code ec;
    const auto size = fs::file_size(p, ec);
    if (!ec && fs::is_regular_file(p, ec)) {
        out->resize(size_t(size));
        in.read(out->data(), std::streamsize(size));
        if (size_t(in.gcount()) != size_t(size)) return false;
        return true;
    }
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) return false;
    *out = ss.str();
    return true;
}

// Splits on commas and whitespace, dropping empty pieces ("1, 2 3" -> 1 2 3), as Mitsuba's tokenize.
std::vector<std::string_view> tokens(std::string_view s) {
    std::vector<std::string_view> out;
    size_t i = 0;
    auto sep = [](char c) { return c == ',' || c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
    while (i < s.size()) {
        while (i < s.size() && sep(s[i])) ++i;
        size_t j = i;
        while (j < s.size() && !sep(s[j])) ++j;
        if (j > i) out.push_back(s.substr(i, j - i));
        i = j;
    }
    return out;
}

// ------------------------------------------------------------------------------------------------
// Parameters and plugins.
enum class Kind : uint8_t { Float, Integer, Boolean, String, Point, Vector, Rgb, Srgb, Spectrum, Transform };

const char* kind_name(Kind k) {
    switch (k) {
        case Kind::Float: return "<float>";
        case Kind::Integer: return "<integer>";
        case Kind::Boolean: return "<boolean>";
        case Kind::String: return "<string>";
        case Kind::Point: return "<point>";
        case Kind::Vector: return "<vector>";
        case Kind::Rgb: return "<rgb>";
        case Kind::Srgb: return "<srgb>";
        case Kind::Spectrum: return "<spectrum>";
        case Kind::Transform: return "<transform>";
    }
    return "?";
}

std::optional<Kind> kind_of_tag(std::string_view tag) {
    if (tag == "float") return Kind::Float;
    if (tag == "integer") return Kind::Integer;
    if (tag == "boolean") return Kind::Boolean;
    if (tag == "string") return Kind::String;
    if (tag == "point") return Kind::Point;
    if (tag == "vector") return Kind::Vector;
    if (tag == "rgb") return Kind::Rgb;
    if (tag == "srgb") return Kind::Srgb;
    if (tag == "spectrum") return Kind::Spectrum;
    if (tag == "transform") return Kind::Transform;
    return std::nullopt;
}

bool is_plugin_tag(std::string_view tag) {
    static const char* tags[] = {"bsdf",   "shape",  "emitter",  "sensor", "film",       "rfilter", "sampler",
                                 "integrator", "medium", "phase", "texture", "subsurface", "ref"};
    for (const char* t : tags)
        if (tag == t) return true;
    return false;
}

struct Prop {
    Kind kind;
    std::string name;
    pugi::xml_node node;
    int line = 0;
    bool used = false;
};

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

// ------------------------------------------------------------------------------------------------
// The loader.
class Loader {
public:
    explicit Loader(const SceneLoadOptions& options) : options_(options) {}

    Scene run(const std::string& path) {
        const Source& src = open_source(path, nullptr, 0, fs::path());
        pugi::xml_node root = src.doc.document_element();
        if (std::string_view(root.name()) != "scene")
            fail(src, src.line_of(root), "the root element is <" + std::string(root.name()) + ">, expected <scene>");
        check_attrs(src, root, {"version"});
        // Mitsuba 2 and 3 (version 2.x, 3.x) changed names and defaults (e.g. lowercase lookat, Cartesian
        // RGB handling): reading their files as 0.x would render something silently different.
        if (pugi::xml_attribute v = root.attribute("version"); v && std::string_view(v.value()).substr(0, 2) != "0.")
            fail(src, src.line_of(root),
                 "scene version " + quote(v.value()) + " is not supported (iris reads the Mitsuba 0.5/0.6 format, version 0.x)");

        // Parameters: <default> gives the fallback, the caller's values win.
        collect_defaults(src, root);
        for (const auto& [k, v] : options_.parameters) params_[k] = v;

        process_scene(src, root);

        if (!have_sensor_) fail(src, src.line_of(root), "the scene has no <sensor> (iris needs a perspective camera)");
        for (const auto& [id, nb] : named_bsdfs_)
            if (!nb.used)
                warn(*nb.src, nb.line, "bsdf " + quote(id) + " is never referenced");
        for (const auto& [id, nt] : named_textures_)
            if (!nt.used)
                warn(*nt.src, nt.line, "texture " + quote(id) + " is never referenced");
        if (scene_.lights.empty()) warn(src, src.line_of(root), "the scene has no emitters; it will render black");

        // The parameter overrides change the scene, so they are part of its identity.
        for (const auto& [k, v] : options_.parameters) fingerprint_.add(k + "=" + v);
        scene_.source = path;
        scene_.fingerprint = fingerprint_.hex();
        return std::move(scene_);
    }

private:
    // ---- files ----------------------------------------------------------------------------------
    const Source& open_source(const std::string& path, const Source* from, int from_line, const fs::path& resolved) {
        auto src = std::make_unique<Source>();
        src->path = path;
        fs::path p = resolved.empty() ? fs::path(path) : resolved;
        src->dir = p.parent_path();
        if (!read_file(p, &src->text)) {
            if (from) fail(*from, from_line, "cannot read included file " + quote(path) + " (resolved to " + p.string() + ")");
            throw SceneError(path + ": cannot read the scene file");
        }
        src->line_starts.push_back(0);
        for (size_t i = 0; i < src->text.size(); ++i)
            if (src->text[i] == '\n') src->line_starts.push_back(i + 1);
        fingerprint_.add(src->text);
        // parse_default: elements, attributes, text, CDATA, escapes; no comments, PIs or declarations.
        pugi::xml_parse_result r =
            src->doc.load_buffer(src->text.data(), src->text.size(), pugi::parse_default, pugi::encoding_auto);
        if (!r) fail(*src, src->line_at(r.offset), std::string("malformed XML: ") + r.description());
        sources_.push_back(std::move(src));
        return *sources_.back();
    }

    fs::path resolve(const Source& src, const std::string& file) const {
        fs::path p(file);
        return p.is_absolute() ? p : src.dir / p;
    }

    // ---- messages -------------------------------------------------------------------------------
    void warn(const Source& src, int line, const std::string& msg) {
        std::string s = src.path + ":" + std::to_string(line) + ": " + msg;
        if (options_.warnings)
            options_.warnings->push_back(s);
        else if (!options_.quiet_warnings)
            std::cerr << "warning: " << s << "\n";
    }

    void check_attrs(const Source& src, pugi::xml_node n, std::initializer_list<const char*> allowed) {
        for (pugi::xml_attribute a : n.attributes()) {
            bool ok = false;
            for (const char* name : allowed) ok = ok || std::string_view(a.name()) == name;
            if (!ok)
                fail(src, src.line_of(n), "unknown attribute " + quote(a.name()) + " on <" + std::string(n.name()) + ">");
        }
    }

    // Element children only; stray text is an error (Mitsuba's schema has no text content).
    void check_no_text(const Source& src, pugi::xml_node n) {
        for (pugi::xml_node c : n.children())
            if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata)
                fail(src, src.line_of(n), "unexpected text inside <" + std::string(n.name()) + ">");
    }

    // ---- $parameters ----------------------------------------------------------------------------
    void collect_defaults(const Source& src, pugi::xml_node root) {
        for (pugi::xml_node c : root.children("default")) {
            check_attrs(src, c, {"name", "value"});
            if (!c.attribute("name") || !c.attribute("value"))
                fail(src, src.line_of(c), "<default> needs name and value attributes");
            params_.emplace(c.attribute("name").value(), c.attribute("value").value());  // first one wins
        }
    }

    // Replaces every $identifier by its parameter value; an unknown one is an error.
    std::string substitute(const Source& src, int line, std::string_view raw) const {
        std::string out;
        size_t i = 0;
        while (i < raw.size()) {
            if (raw[i] != '$') {
                out += raw[i++];
                continue;
            }
            size_t j = i + 1;
            while (j < raw.size() && (std::isalnum(static_cast<unsigned char>(raw[j])) || raw[j] == '_')) ++j;
            std::string name(raw.substr(i + 1, j - i - 1));
            if (name.empty()) fail(src, line, "stray '$' in " + quote(raw));
            auto it = params_.find(name);
            if (it == params_.end())
                fail(src, line, "undefined parameter $" + name + " (give it with <default> or on the command line)");
            out += it->second;
            i = j;
        }
        return out;
    }

    std::optional<std::string> opt_attr(const Source& src, pugi::xml_node n, const char* name) const {
        pugi::xml_attribute a = n.attribute(name);
        if (!a) return std::nullopt;
        return substitute(src, src.line_of(n), a.value());
    }

    std::string attr(const Source& src, pugi::xml_node n, const char* name) const {
        auto v = opt_attr(src, n, name);
        if (!v) fail(src, src.line_of(n), "<" + std::string(n.name()) + "> needs a " + quote(name) + " attribute");
        return *v;
    }

    // ---- numbers --------------------------------------------------------------------------------
    float parse_float(const Source& src, int line, std::string_view s, const std::string& what) const {
        float v = 0;
        const char* first = s.data();
        const char* last = s.data() + s.size();
        while (first < last && std::isspace(static_cast<unsigned char>(*first))) ++first;
        while (last > first && std::isspace(static_cast<unsigned char>(last[-1]))) --last;
        if (first < last && *first == '+') ++first;
        auto [ptr, ec] = std::from_chars(first, last, v);
        if (first == last || ec != std::errc() || ptr != last || !std::isfinite(v))
            fail(src, line, "bad number " + quote(s) + " for " + what);
        return v;
    }

    int parse_int(const Source& src, int line, std::string_view s, const std::string& what) const {
        int v = 0;
        const char* first = s.data();
        const char* last = s.data() + s.size();
        while (first < last && std::isspace(static_cast<unsigned char>(*first))) ++first;
        while (last > first && std::isspace(static_cast<unsigned char>(last[-1]))) --last;
        if (first < last && *first == '+') ++first;
        auto [ptr, ec] = std::from_chars(first, last, v);
        if (first == last || ec != std::errc() || ptr != last) fail(src, line, "bad integer " + quote(s) + " for " + what);
        return v;
    }

    std::vector<float> parse_floats(const Source& src, int line, std::string_view s, const std::string& what) const {
        std::vector<float> out;
        for (std::string_view t : tokens(s)) out.push_back(parse_float(src, line, t, what));
        return out;
    }

    Vec3 parse_vec3(const Source& src, int line, std::string_view s, const std::string& what) const {
        std::vector<float> v = parse_floats(src, line, s, what);
        if (v.size() != 3) fail(src, line, "expected three numbers for " + what + ", got " + quote(s));
        return Vec3(v[0], v[1], v[2]);
    }

    // ---- reading a plugin element ---------------------------------------------------------------
    Plugin read_plugin(const Source& src, pugi::xml_node n) {
        check_attrs(src, n, {"type", "id", "name"});
        check_no_text(src, n);
        Plugin p;
        p.src = &src;
        p.node = n;
        p.line = src.line_of(n);
        p.tag = n.name();
        p.type = attr(src, n, "type");
        if (auto id = opt_attr(src, n, "id")) p.id = *id;
        for (pugi::xml_node c : n.children()) {
            if (c.type() != pugi::node_element) continue;
            std::string tag = c.name();
            if (auto k = kind_of_tag(tag)) {
                Prop prop;
                prop.kind = *k;
                prop.node = c;
                prop.line = src.line_of(c);
                prop.name = attr(src, c, "name");
                for (const Prop& other : p.props)
                    if (other.name == prop.name)
                        fail(src, prop.line, "parameter " + quote(prop.name) + " given twice (first at line " +
                                                 std::to_string(other.line) + ")");
                p.props.push_back(prop);
            } else if (is_plugin_tag(tag)) {
                p.children.push_back(c);
            } else if (tag == "blackbody" || tag == "animation") {
                fail(src, src.line_of(c), "<" + tag + "> is not supported");
            } else {
                fail(src, src.line_of(c), "unknown element <" + tag + "> in " + p.what());
            }
        }
        register_id(src, p.line, p.id, p.tag);
        return p;
    }

    void register_id(const Source& src, int line, const std::string& id, const std::string& tag) {
        if (id.empty()) return;
        auto [it, inserted] = ids_.emplace(id, IdInfo{tag, src.path, line});
        if (!inserted)
            fail(src, line, "duplicate id " + quote(id) + " (first used at " + it->second.file + ":" +
                                std::to_string(it->second.line) + ")");
    }

    Prop* find(Plugin& p, const std::string& name) {
        for (Prop& prop : p.props)
            if (prop.name == name) return &prop;
        return nullptr;
    }

    [[noreturn]] void wrong_kind(const Plugin& p, const Prop& prop, const char* expected) {
        fail(*p.src, prop.line, "parameter " + quote(prop.name) + " of " + p.what() + " must be " + expected + ", not " +
                                    kind_name(prop.kind));
    }

    std::string what(const Plugin& p, const Prop& prop) const { return "parameter " + quote(prop.name) + " of " + p.what(); }

    // The "value" attribute of a simple parameter, substituted.
    std::string value_of(const Plugin& p, const Prop& prop) {
        check_attrs(*p.src, prop.node, {"name", "value"});
        check_no_text(*p.src, prop.node);
        return attr(*p.src, prop.node, "value");
    }

    std::optional<float> get_float(Plugin& p, const std::string& name) {
        Prop* prop = find(p, name);
        if (!prop) return std::nullopt;
        prop->used = true;
        if (prop->kind == Kind::Integer) return float(parse_int(*p.src, prop->line, value_of(p, *prop), what(p, *prop)));
        if (prop->kind != Kind::Float) wrong_kind(p, *prop, "a <float>");
        return parse_float(*p.src, prop->line, value_of(p, *prop), what(p, *prop));
    }
    float get_float(Plugin& p, const std::string& name, float def) { return get_float(p, name).value_or(def); }

    std::optional<int> get_int(Plugin& p, const std::string& name) {
        Prop* prop = find(p, name);
        if (!prop) return std::nullopt;
        prop->used = true;
        if (prop->kind != Kind::Integer) wrong_kind(p, *prop, "an <integer>");
        return parse_int(*p.src, prop->line, value_of(p, *prop), what(p, *prop));
    }
    int get_int(Plugin& p, const std::string& name, int def) { return get_int(p, name).value_or(def); }

    bool get_bool(Plugin& p, const std::string& name, bool def) {
        Prop* prop = find(p, name);
        if (!prop) return def;
        prop->used = true;
        if (prop->kind != Kind::Boolean) wrong_kind(p, *prop, "a <boolean>");
        std::string v = lower(value_of(p, *prop));
        if (v == "true") return true;
        if (v == "false") return false;
        fail(*p.src, prop->line, "bad boolean " + quote(v) + " for " + what(p, *prop) + " (true or false)");
    }

    std::optional<std::string> get_string(Plugin& p, const std::string& name) {
        Prop* prop = find(p, name);
        if (!prop) return std::nullopt;
        prop->used = true;
        if (prop->kind != Kind::String) wrong_kind(p, *prop, "a <string>");
        return value_of(p, *prop);
    }
    std::string get_string(Plugin& p, const std::string& name, const std::string& def) {
        return get_string(p, name).value_or(def);
    }

    std::optional<Vec3> get_point(Plugin& p, const std::string& name) {
        Prop* prop = find(p, name);
        if (!prop) return std::nullopt;
        prop->used = true;
        if (prop->kind != Kind::Point && prop->kind != Kind::Vector) wrong_kind(p, *prop, "a <point>");
        const Source& src = *p.src;
        check_attrs(src, prop->node, {"name", "x", "y", "z", "value"});
        check_no_text(src, prop->node);
        if (auto v = opt_attr(src, prop->node, "value")) {
            if (prop->node.attribute("x") || prop->node.attribute("y") || prop->node.attribute("z"))
                fail(src, prop->line, what(p, *prop) + ": give either value or x/y/z");
            return parse_vec3(src, prop->line, *v, what(p, *prop));
        }
        Vec3 r(0.0f);
        const char* axes[3] = {"x", "y", "z"};
        for (int i = 0; i < 3; ++i)
            if (auto v = opt_attr(src, prop->node, axes[i])) r[i] = parse_float(src, prop->line, *v, what(p, *prop));
        return r;
    }

    // <spectrum>, <rgb> or <srgb> -> linear RGB (Mitsuba 0.5 RGB mode; see scenes/thesis/README.md).
    std::optional<RGB> get_spectrum(Plugin& p, const std::string& name) {
        Prop* prop = find(p, name);
        if (!prop) return std::nullopt;
        prop->used = true;
        const Source& src = *p.src;
        const int line = prop->line;
        const std::string w = what(p, *prop);
        switch (prop->kind) {
            case Kind::Spectrum: {
                check_attrs(src, prop->node, {"name", "value", "filename"});
                check_no_text(src, prop->node);
                if (prop->node.attribute("filename"))
                    fail(src, line, w + ": spectra from files are not supported; give value=\"nm:value, ...\"");
                std::string v = attr(src, prop->node, "value");
                std::vector<std::string_view> t = tokens(v);
                bool sampled = !t.empty() && t[0].find(':') != std::string_view::npos;
                if (sampled) {
                    std::vector<float> wl, val;
                    for (std::string_view tok : t) {
                        size_t c = tok.find(':');
                        if (c == std::string_view::npos || tok.find(':', c + 1) != std::string_view::npos)
                            fail(src, line, w + ": bad wavelength:value pair " + quote(tok));
                        wl.push_back(parse_float(src, line, tok.substr(0, c), w));
                        val.push_back(parse_float(src, line, tok.substr(c + 1), w));
                    }
                    try {
                        return spectrum_to_rgb(wl, val);
                    } catch (const std::invalid_argument& e) {
                        fail(src, line, w + ": " + e.what());
                    }
                }
                // One number: the same value in every channel (measured with Mitsuba: value="1"
                // renders as (1,1,1)). Three numbers: RGB, as Mitsuba's RGB build reads them.
                if (t.size() == 1) return RGB(parse_float(src, line, t[0], w));
                if (t.size() == 3)
                    return RGB(parse_float(src, line, t[0], w), parse_float(src, line, t[1], w),
                               parse_float(src, line, t[2], w));
                fail(src, line, w + ": a <spectrum> value is one number, three numbers or nm:value pairs, not " + quote(v));
            }
            case Kind::Rgb: {
                std::vector<float> v = parse_floats(src, line, value_of(p, *prop), w);
                if (v.size() == 1) return RGB(v[0]);
                if (v.size() == 3) return RGB(v[0], v[1], v[2]);
                fail(src, line, w + ": an <rgb> value is one or three numbers");
            }
            case Kind::Srgb: {
                std::string v = value_of(p, *prop);
                RGB c;
                if (!v.empty() && v[0] == '#') {
                    if (v.size() != 7) fail(src, line, w + ": bad colour " + quote(v) + " (expected #rrggbb)");
                    for (int i = 0; i < 3; ++i) {
                        unsigned byte = 0;
                        auto [ptr, ec] = std::from_chars(v.data() + 1 + 2 * i, v.data() + 3 + 2 * i, byte, 16);
                        if (ec != std::errc() || ptr != v.data() + 3 + 2 * i)
                            fail(src, line, w + ": bad colour " + quote(v) + " (expected #rrggbb)");
                        c[i] = float(byte) / 255.0f;
                    }
                } else {
                    std::vector<float> f = parse_floats(src, line, v, w);
                    if (f.size() == 1) c = RGB(f[0]);
                    else if (f.size() == 3) c = RGB(f[0], f[1], f[2]);
                    else fail(src, line, w + ": an <srgb> value is #rrggbb, one or three numbers");
                }
                return RGB(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b));
            }
            default: wrong_kind(p, *prop, "a <spectrum>, <rgb> or <srgb>");
        }
    }
    RGB get_spectrum(Plugin& p, const std::string& name, RGB def) { return get_spectrum(p, name).value_or(def); }

    // A refractive index given as a number or as one of Mitsuba's material names.
    float get_ior(Plugin& p, const std::string& name, const char* def) {
        Prop* prop = find(p, name);
        float ior = 0;
        if (!prop) {
            dielectric_ior(def, &ior);
            return ior;
        }
        if (prop->kind == Kind::String) {
            prop->used = true;
            std::string v = value_of(p, *prop);
            if (!dielectric_ior(v, &ior)) fail(*p.src, prop->line, what(p, *prop) + ": unknown material " + quote(v));
            return ior;
        }
        ior = *get_float(p, name);
        if (!(ior > 0)) fail(*p.src, prop->line, what(p, *prop) + " must be positive");
        return ior;
    }

    std::optional<Transform> get_transform(Plugin& p, const std::string& name) {
        Prop* prop = find(p, name);
        if (!prop) return std::nullopt;
        prop->used = true;
        if (prop->kind != Kind::Transform) wrong_kind(p, *prop, "a <transform>");
        return parse_transform(*p.src, prop->node);
    }

    // <transform>: the operations apply in the order listed, M = T_n ... T_1.
    Transform parse_transform(const Source& src, pugi::xml_node n) {
        check_attrs(src, n, {"name"});
        check_no_text(src, n);
        Transform m;
        for (pugi::xml_node c : n.children()) {
            if (c.type() != pugi::node_element) continue;
            const std::string tag = c.name();
            const int line = src.line_of(c);
            check_no_text(src, c);
            auto num = [&](const char* a, float def) {
                auto v = opt_attr(src, c, a);
                return v ? parse_float(src, line, *v, "<" + tag + "> attribute " + a) : def;
            };
            Transform op;
            if (tag == "translate") {
                check_attrs(src, c, {"x", "y", "z", "value"});
                Vec3 t = c.attribute("value") ? parse_vec3(src, line, attr(src, c, "value"), "<translate>")
                                              : Vec3(num("x", 0), num("y", 0), num("z", 0));
                op = Transform::translate(t);
            } else if (tag == "scale") {
                check_attrs(src, c, {"x", "y", "z", "value"});
                Vec3 s;
                if (c.attribute("value")) {
                    if (c.attribute("x") || c.attribute("y") || c.attribute("z"))
                        fail(src, line, "<scale>: give either value or x/y/z");
                    std::vector<float> v = parse_floats(src, line, attr(src, c, "value"), "<scale>");
                    if (v.size() == 1) s = Vec3(v[0]);
                    else if (v.size() == 3) s = Vec3(v[0], v[1], v[2]);
                    else fail(src, line, "<scale> value is one or three numbers");
                } else {
                    s = Vec3(num("x", 1), num("y", 1), num("z", 1));
                }
                if (s.x == 0 || s.y == 0 || s.z == 0) fail(src, line, "<scale> by zero");
                op = Transform::scale(s);
            } else if (tag == "rotate") {
                check_attrs(src, c, {"x", "y", "z", "angle"});
                Vec3 axis(num("x", 0), num("y", 0), num("z", 0));
                if (length(axis) == 0) fail(src, line, "<rotate> needs a non-zero axis (x, y, z)");
                op = Transform::rotate(axis, num("angle", 0));  // degrees
            } else if (tag == "matrix") {
                check_attrs(src, c, {"value"});
                std::vector<float> v = parse_floats(src, line, attr(src, c, "value"), "<matrix>");
                if (v.size() != 16) fail(src, line, "<matrix> needs 16 numbers (row-major 4x4), got " + std::to_string(v.size()));
                for (int i = 0; i < 4; ++i)
                    for (int j = 0; j < 4; ++j) op.m[i][j] = v[4 * i + j];
                if (op.m[3][0] != 0 || op.m[3][1] != 0 || op.m[3][2] != 0 || op.m[3][3] != 1)
                    fail(src, line, "<matrix>: the last row must be 0 0 0 1 (projective transforms are not supported)");
            } else if (tag == "lookAt" || tag == "lookat") {
                check_attrs(src, c, {"origin", "target", "up"});
                Vec3 o = parse_vec3(src, line, attr(src, c, "origin"), "<lookAt> origin");
                Vec3 t = parse_vec3(src, line, attr(src, c, "target"), "<lookAt> target");
                Vec3 up = parse_vec3(src, line, attr(src, c, "up"), "<lookAt> up");
                Vec3 d = t - o;
                if (length(d) == 0) fail(src, line, "<lookAt> origin and target coincide");
                if (length(up) == 0 || length(cross(normalize(up), normalize(d))) < 1e-6f)
                    fail(src, line, "<lookAt> up is zero or parallel to the view direction");
                op = Transform::look_at(o, t, up);
            } else {
                fail(src, line, "unknown transform operation <" + tag + ">");
            }
            m = op * m;
        }
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                if (!std::isfinite(m.m[i][j])) fail(src, src.line_of(n), "the transform is not finite");
        // Singular relative to the size of its columns, so that tiny but valid scales still pass.
        double scale = 1;
        for (int j = 0; j < 3; ++j)
            scale *= std::sqrt(m.m[0][j] * m.m[0][j] + m.m[1][j] * m.m[1][j] + m.m[2][j] * m.m[2][j]);
        const double det = m.determinant3x3();
        if (!std::isfinite(det) || !(std::abs(det) > 1e-12 * scale)) fail(src, src.line_of(n), "the transform is singular");
        return m;
    }

    // Every parameter must have been queried, or be one the plugin accepts without using it.
    void finish(Plugin& p, const IgnoreRule& ignore = {}) {
        for (Prop& prop : p.props) {
            if (prop.used) continue;
            const char* why = ignore ? ignore(prop.name) : nullptr;
            if (why)
                warn(*p.src, prop.line, "parameter " + quote(prop.name) + " of " + p.what() + " ignored: " + why);
            else
                fail(*p.src, prop.line, "unknown parameter " + quote(prop.name) + " for " + p.what());
        }
    }

    void no_children(const Plugin& p) {
        if (p.children.empty()) return;
        pugi::xml_node c = p.children[0];
        // A nested <texture> is a textured parameter (Mitsuba's bitmap, checkerboard, ...): name the
        // plugin, so the user knows what iris lacks rather than reading a syntax complaint.
        if (std::string(c.name()) == "texture")
            fail(*p.src, p.src->line_of(c),
                 "unsupported plugin " + quote(c.attribute("type").value()) + " (texture for parameter " +
                     quote(c.attribute("name").value()) + " of " + p.what() + "; iris textures BSDF parameters only)");
        fail(*p.src, p.src->line_of(c), "<" + std::string(c.name()) + "> is not allowed inside " + p.what());
    }

    // ---- the scene ------------------------------------------------------------------------------
    void process_scene(const Source& src, pugi::xml_node root) {
        check_no_text(src, root);
        for (pugi::xml_node c : root.children()) {
            if (c.type() != pugi::node_element) continue;
            const std::string tag = c.name();
            if (tag == "default") continue;  // collected before
            if (tag == "include") include(src, c);
            else if (tag == "integrator") integrator(src, c);
            else if (tag == "sensor") sensor(src, c);
            else if (tag == "bsdf") top_level_bsdf(src, c);
            else if (tag == "shape") shape(src, c);
            else if (tag == "emitter") emitter(src, c);
            else if (tag == "medium") medium(src, c);
            else if (tag == "texture") top_level_texture(src, c);
            else if (tag == "alias" || tag == "null" || tag == "phase" || tag == "subsurface")
                fail(src, src.line_of(c), "<" + tag + "> is not supported by iris");
            else fail(src, src.line_of(c), "unknown element <" + tag + "> in <scene>");
        }
    }

    void include(const Source& src, pugi::xml_node n) {
        check_attrs(src, n, {"filename"});
        check_no_text(src, n);
        const int line = src.line_of(n);
        if (++include_depth_ > 16) fail(src, line, "<include> nested more than 16 deep (a cycle?)");
        std::string file = attr(src, n, "filename");
        const fs::path resolved = resolve(src, file);
        const Source& inc = open_source(resolved.string(), &src, line, resolved);
        pugi::xml_node root = inc.doc.document_element();
        if (std::string_view(root.name()) != "scene")
            fail(inc, inc.line_of(root), "an included file must have <scene> as its root element");
        check_attrs(inc, root, {"version"});
        collect_defaults(inc, root);
        process_scene(inc, root);
        --include_depth_;
    }

    void integrator(const Source& src, pugi::xml_node n) {
        Plugin p = read_plugin(src, n);
        if (have_integrator_) fail(src, p.line, "a second <integrator>");
        have_integrator_ = true;
        for (pugi::xml_node c : p.children)
            if (std::string_view(c.name()) == "integrator")
                fail(src, src.line_of(c), "nested integrators (e.g. irradiance-cache wrappers) are not supported");
        no_children(p);
        // Mitsuba's meaning: maxDepth = longest path in edges, -1 = unlimited; RR from rrDepth on.
        int max_depth = get_int(p, "maxDepth", -1);
        int rr_depth = get_int(p, "rrDepth", 5);
        if (max_depth < -1) fail(src, find(p, "maxDepth")->line, "maxDepth must be -1 (unlimited) or >= 0");
        if (rr_depth < 1) fail(src, find(p, "rrDepth")->line, "rrDepth must be >= 1");
        scene_.defaults.max_depth = max_depth;
        scene_.defaults.rr_depth = rr_depth;
        finish(p, [](const std::string&) {
            return "a setting of Mitsuba's own integrator; iris takes only maxDepth and rrDepth from it";
        });
    }

    void sensor(const Source& src, pugi::xml_node n) {
        Plugin p = read_plugin(src, n);
        if (have_sensor_) fail(src, p.line, "a second <sensor>");
        have_sensor_ = true;
        if (p.type != "perspective") fail(src, p.line, "unsupported sensor type " + quote(p.type) + " (only perspective)");

        // Film and sampler first: the field of view depends on the aspect ratio.
        FilmSettings film;
        bool have_film = false, have_sampler = false;
        for (pugi::xml_node c : p.children) {
            std::string tag = c.name();
            if (tag == "film") {
                if (have_film) fail(src, src.line_of(c), "a second <film>");
                have_film = true;
                film = read_film(src, c);
            } else if (tag == "sampler") {
                if (have_sampler) fail(src, src.line_of(c), "a second <sampler>");
                have_sampler = true;
                read_sampler(src, c);
            } else {
                fail(src, src.line_of(c), "<" + tag + "> is not allowed inside a sensor");
            }
        }
        scene_.film = film;

        Camera& cam = scene_.camera;
        cam = Camera();
        cam.to_world = get_transform(p, "toWorld").value_or(Transform());
        std::optional<float> fov = get_float(p, "fov");
        std::optional<std::string> focal = get_string(p, "focalLength");
        if (fov && focal) fail(src, p.line, "give either fov or focalLength, not both");
        if (fov) {
            std::string axis = lower(get_string(p, "fovAxis", "x"));
            if (axis == "x") cam.fov_axis = FovAxis::X;
            else if (axis == "y") cam.fov_axis = FovAxis::Y;
            else if (axis == "diagonal") cam.fov_axis = FovAxis::Diagonal;
            else if (axis == "smaller") cam.fov_axis = FovAxis::Smaller;
            else if (axis == "larger") cam.fov_axis = FovAxis::Larger;
            else fail(src, find(p, "fovAxis")->line, "fovAxis must be x, y, diagonal, smaller or larger, not " + quote(axis));
            cam.fov_degrees = *fov;
        } else {
            // Mitsuba's default: a 50 mm lens on 35 mm film, as a diagonal field of view.
            std::string f = focal.value_or("50mm");
            const int line = focal ? find(p, "focalLength")->line : p.line;
            if (f.size() > 2 && f.compare(f.size() - 2, 2, "mm") == 0) f.resize(f.size() - 2);
            float mm = parse_float(src, line, f, "focalLength");
            if (!(mm > 0)) fail(src, line, "focalLength must be positive");
            cam.fov_degrees = float(2.0 * std::atan(std::sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * mm)) * (180.0 / double(kPi)));
            cam.fov_axis = FovAxis::Diagonal;
            if (find(p, "fovAxis")) get_string(p, "fovAxis");  // meaningless without fov; accepted as Mitsuba does
        }
        if (!(cam.fov_degrees > 0 && cam.fov_degrees < 180)) fail(src, p.line, "fov must lie in (0, 180) degrees");
        cam.near_clip = get_float(p, "nearClip", 1e-2f);
        cam.far_clip = get_float(p, "farClip", 1e4f);
        if (!(cam.near_clip > 0) || !(cam.far_clip > cam.near_clip))
            fail(src, p.line, "need 0 < nearClip < farClip");
        // A pinhole camera has no focus: accepted silently (every Mitsuba exporter writes it).
        get_float(p, "focusDistance");
        finish(p, [](const std::string& name) -> const char* {
            if (name == "shutterOpen" || name == "shutterClose") return "iris renders static scenes (no motion blur)";
            return nullptr;
        });
        camera_prepare(cam, film.width, film.height);
        if (!is_finite(cam.forward) || !is_finite(cam.right) || !is_finite(cam.up))
            fail(src, p.line, "the camera transform is degenerate");
    }

    FilmSettings read_film(const Source& src, pugi::xml_node n) {
        Plugin p = read_plugin(src, n);
        if (p.type != "hdrfilm" && p.type != "ldrfilm")
            fail(src, p.line, "unsupported film type " + quote(p.type) + " (hdrfilm or ldrfilm)");
        FilmSettings film;
        film.width = get_int(p, "width", 768);
        film.height = get_int(p, "height", 576);
        if (film.width <= 0 || film.height <= 0 || film.width > 65536 || film.height > 65536)
            fail(src, p.line, "film width and height must be in 1..65536");
        for (const char* crop : {"cropOffsetX", "cropOffsetY", "cropWidth", "cropHeight"})
            if (Prop* c = find(p, crop)) fail(src, c->line, "crop windows (" + std::string(crop) + ") are not supported");
        bool have_filter = false;
        for (pugi::xml_node c : p.children) {
            if (std::string_view(c.name()) != "rfilter")
                fail(src, src.line_of(c), "<" + std::string(c.name()) + "> is not allowed inside a film");
            if (have_filter) fail(src, src.line_of(c), "a second <rfilter>");
            have_filter = true;
            Plugin f = read_plugin(src, c);
            no_children(f);
            if (f.type == "gaussian") {
                // Mitsuba: standard deviation 0.5 px, support 4 standard deviations.
                film.filter = FilterType::Gaussian;
                film.filter_stddev = get_float(f, "stddev", 0.5f);
                if (!(film.filter_stddev > 0)) fail(src, f.line, "stddev must be positive");
                film.filter_radius = 4.0f * film.filter_stddev;
            } else if (f.type == "box") {
                film.filter = FilterType::Box;
                film.filter_radius = get_float(f, "radius", 0.5f);
                if (!(film.filter_radius > 0)) fail(src, f.line, "radius must be positive");
            } else {
                fail(src, f.line, "unsupported reconstruction filter " + quote(f.type) + " (gaussian or box)");
            }
            finish(f);
        }
        finish(p, [](const std::string& name) -> const char* {
            static const std::set<std::string> output = {"banner",   "pixelFormat", "componentFormat", "fileFormat",
                                                         "tonemapMethod", "gamma", "exposure", "highQualityEdges",
                                                         "attachLog", "key", "burn"};
            if (output.count(name) || name.rfind("label[", 0) == 0)
                return "an output-format setting; iris writes linear HDR images";
            return nullptr;
        });
        return film;
    }

    void read_sampler(const Source& src, pugi::xml_node n) {
        Plugin p = read_plugin(src, n);
        no_children(p);
        if (auto spp = get_int(p, "sampleCount")) {
            if (*spp <= 0) fail(src, find(p, "sampleCount")->line, "sampleCount must be positive");
            scene_.defaults.spp = *spp;
        }
        finish(p, [](const std::string&) { return "iris uses its own sample generator; only sampleCount is taken"; });
    }

    // ---- BSDFs ----------------------------------------------------------------------------------
    // A BSDF parameter given by a texture (see "textures" below): which one, and where.
    struct TexParam {
        int16_t index = -1;
        int line = 0;
        bool used = false;
    };
    using TexParams = std::map<std::string, TexParam>;

    struct NamedTexture {
        int16_t index = -1;
        const Source* src = nullptr;
        int line = 0;
        bool used = false;
    };

    struct NamedBsdf {
        Bsdf bsdf;
        const Source* src = nullptr;
        int line = 0;
        int index = -1;  // in scene_.bsdfs once a shape uses it
        bool used = false;
    };

    // A top-level BSDF only matters through its id (parse_bsdf stores it for later <ref>s).
    void top_level_bsdf(const Source& src, pugi::xml_node n) {
        std::string id;
        int line = 0;
        parse_bsdf(src, n, &id, &line);
        if (id.empty()) warn(src, line, "a top-level bsdf without an id can never be used");
    }

    // Parses a <bsdf> element; a BSDF with an id is also stored for later <ref>s.
    Bsdf parse_bsdf(const Source& src, pugi::xml_node n, std::string* id_out = nullptr, int* line_out = nullptr) {
        Plugin p = read_plugin(src, n);
        Bsdf b;
        const std::string& t = p.type;
        auto mitsuba_ignores = [](const char* name) {
            return [name](const std::string& param) -> const char* {
                if (param == name) return "Mitsuba 0.5 ignores it too (unqueried attribute)";
                return nullptr;
            };
        };
        IgnoreRule ignore;
        // Name an unsupported BSDF plugin first: wrappers such as mask nest a <bsdf>, which would otherwise
        // be reported as a misplaced element.
        static const char* const kSupported[] = {"twosided",     "bumpmap",        "diffuse",         "roughdiffuse",
                                                 "dielectric",   "thindielectric", "roughdielectric", "conductor",
                                                 "roughconductor", "plastic",      "roughplastic",    "ward"};
        if (std::find(std::begin(kSupported), std::end(kSupported), t) == std::end(kSupported))
            fail(src, p.line, "unsupported plugin " + quote(t) + " (bsdf)");
        if (t == "twosided") {
            // Wraps one BSDF and makes it act alike on both sides.
            if (p.children.size() != 1)
                fail(src, p.line, "twosided needs exactly one nested <bsdf> or <ref> (iris has no separate back-side BSDF)");
            pugi::xml_node c = p.children[0];
            std::string tag = c.name();
            if (tag == "bsdf") {
                std::string nested_id;
                b = parse_bsdf(src, c, &nested_id);
                if (!nested_id.empty()) named_bsdfs_[nested_id].used = true;  // used through the wrapper
            } else if (tag == "ref") {
                b = named_bsdf(src, c).bsdf;
            } else {
                fail(src, src.line_of(c), "<" + tag + "> is not allowed inside bsdf \"twosided\"");
            }
            // As in Mitsuba: the wrapper mirrors the front side onto the back, which means nothing for
            // a surface that lets light through (its back side is the other medium's view of it).
            if (b.type == BsdfType::Dielectric || b.type == BsdfType::ThinDielectric || b.type == BsdfType::RoughDielectric)
                fail(src, p.line, "twosided cannot wrap a BSDF that transmits light (dielectric, thindielectric, roughdielectric)");
            b.two_sided = true;
        } else if (t == "bumpmap") {
            // A displacement texture and one BSDF, nested or referenced, in either order; the BSDF's shading
            // normal is then tilted by the texture's gradient (Bsdf::tex_bump, applied by Scene::intersect).
            int16_t bump = -1;
            bool have_bsdf = false;
            auto take_bsdf = [&](const Bsdf& nested, int line) {
                if (have_bsdf) fail(src, line, "bumpmap takes exactly one nested <bsdf> or <ref>");
                have_bsdf = true;
                b = nested;
            };
            for (pugi::xml_node c : p.children) {
                const std::string tag = c.name();
                const int line = src.line_of(c);
                if (tag == "texture") {
                    if (bump >= 0) fail(src, line, "bumpmap takes exactly one displacement <texture>");
                    // As Mitsuba: a height map read with the implicit gamma would be decoded as sRGB colour.
                    if (std::string(c.attribute("type").value()) == "bitmap" && !c.find_child_by_attribute("name", "gamma"))
                        fail(src, line, "a bitmap used as a bump map needs an explicit gamma (most likely <float name=\"gamma\" value=\"1\"/>)");
                    // Mitsuba checks only a bitmap directly inside; one deeper (in a `scale`) is decoded with the
                    // file's own curve there too, which iris follows, but says so.
                    for (const pugi::xpath_node& x : c.select_nodes(".//texture[@type='bitmap']"))
                        if (!x.node().find_child_by_attribute("name", "gamma"))
                            warn(src, src.line_of(x.node()), "height-map bitmap without an explicit gamma: decoded with the file's own "
                                                      "curve (sRGB for 8-bit images), as in Mitsuba; give gamma 1 for linear heights");
                    bump = parse_texture(src, c, "displacement texture of bsdf \"bumpmap\"");
                } else if (tag == "bsdf") {
                    std::string nested_id;
                    take_bsdf(parse_bsdf(src, c, &nested_id), line);
                    if (!nested_id.empty()) named_bsdfs_[nested_id].used = true;  // used through the wrapper
                } else if (tag == "ref" && named_textures_.count(c.attribute("id").value())) {
                    if (bump >= 0) fail(src, line, "bumpmap takes exactly one displacement <texture>");
                    bump = texture_ref(src, c);
                } else if (tag == "ref") {
                    take_bsdf(named_bsdf(src, c).bsdf, line);
                } else {
                    fail(src, line, "<" + tag + "> is not allowed inside bsdf \"bumpmap\"");
                }
            }
            if (bump < 0) fail(src, p.line, "bumpmap needs a displacement <texture>");
            if (!have_bsdf) fail(src, p.line, "bumpmap needs a nested <bsdf> or <ref>");
            if (b.tex_bump >= 0) fail(src, p.line, "a bumpmap inside a bumpmap is not supported (iris keeps one per BSDF)");
            b.tex_bump = bump;
        } else {
            TexParams tex = bsdf_textures(p);
            if (t == "diffuse") {
                b.type = BsdfType::Diffuse;
                b.diffuse = spectrum_param(p, tex, "reflectance", RGB(0.5f), &b.tex_diffuse);
            } else if (t == "roughdiffuse") {
                b.type = BsdfType::RoughDiffuse;
                b.diffuse = spectrum_param(p, tex, "reflectance", RGB(0.5f), &b.tex_diffuse);
                b.alpha_u = b.alpha_v = alpha_param(p, tex, "alpha", 0.2f, &b.tex_alpha_u);
                b.tex_alpha_v = b.tex_alpha_u;
                if (get_bool(p, "useFastApprox", false))
                    warn(src, find(p, "useFastApprox")->line,
                         "useFastApprox ignored: iris always evaluates the full Oren-Nayar model");
            } else if (t == "dielectric" || t == "thindielectric" || t == "roughdielectric") {
                b.type = t == "dielectric"       ? BsdfType::Dielectric
                         : t == "thindielectric" ? BsdfType::ThinDielectric
                                                 : BsdfType::RoughDielectric;
                b.ior = get_ior(p, "intIOR", "bk7") / get_ior(p, "extIOR", "air");
                b.specular = spectrum_param(p, tex, "specularReflectance", RGB(1.0f), &b.tex_specular);
                b.transmittance = spectrum_param(p, tex, "specularTransmittance", RGB(1.0f), &b.tex_transmittance);
                if (t == "roughdielectric") {
                    b.distribution = distribution(p);
                    anisotropic_alpha(p, tex, &b);
                    // Refraction through an index-matched rough interface goes straight on: a Dirac event
                    // the microfacet model has no density for.
                    if (std::abs(b.ior - 1.0f) < 1e-4f)
                        fail(src, p.line, "roughdielectric: intIOR equals extIOR (an index-matched interface does not scatter)");
                }
                ignore = [](const std::string& param) -> const char* {
                    if (param == "diffuseReflectance" || param == "reflectance")
                        return "Mitsuba 0.5 ignores it too (unqueried attribute)";
                    if (param == "sampleVisible") return "a sampling strategy only; it does not change the result";
                    return nullptr;
                };
            } else if (t == "conductor" || t == "roughconductor") {
                b.type = t == "conductor" ? BsdfType::Conductor : BsdfType::RoughConductor;
                const std::string material = get_string(p, "material", "Cu");
                RGB eta, k;
                if (!conductor_ior(material, &eta, &k))
                    fail(src, find(p, "material")->line, "unknown conductor material " + quote(material));
                eta = get_spectrum(p, "eta", eta);
                k = get_spectrum(p, "k", k);
                const float ext = get_ior(p, "extEta", "air");
                b.eta = eta / ext;
                b.k = k / ext;
                b.specular = spectrum_param(p, tex, "specularReflectance", RGB(1.0f), &b.tex_specular);
                if (t == "roughconductor") {
                    b.distribution = distribution(p);
                    anisotropic_alpha(p, tex, &b);
                    ignore = [](const std::string& param) -> const char* {
                        if (param == "reflectance") return "Mitsuba 0.5 ignores it too (unqueried attribute)";
                        if (param == "sampleVisible") return "a sampling strategy only; it does not change the result";
                        return nullptr;
                    };
                } else {
                    ignore = mitsuba_ignores("reflectance");
                }
            } else if (t == "plastic" || t == "roughplastic") {
                b.type = t == "plastic" ? BsdfType::Plastic : BsdfType::RoughPlastic;
                b.ior = get_ior(p, "intIOR", "polypropylene") / get_ior(p, "extIOR", "air");
                b.diffuse = spectrum_param(p, tex, "diffuseReflectance", RGB(0.5f), &b.tex_diffuse);
                b.specular = spectrum_param(p, tex, "specularReflectance", RGB(1.0f), &b.tex_specular);
                b.nonlinear = get_bool(p, "nonlinear", false);
                if (t == "roughplastic") {
                    b.distribution = distribution(p);
                    b.alpha_u = b.alpha_v = alpha_param(p, tex, "alpha", 0.1f, &b.tex_alpha_u);
                    b.tex_alpha_v = b.tex_alpha_u;
                    ignore = [](const std::string& param) -> const char* {
                        if (param == "sampleVisible") return "a sampling strategy only; it does not change the result";
                        return nullptr;
                    };
                }
            } else if (t == "ward") {
                b.type = BsdfType::Ward;
                const std::string variant = lower(get_string(p, "variant", "balanced"));
                if (variant == "ward") b.ward_variant = WardVariant::Ward;
                else if (variant == "ward-duer") b.ward_variant = WardVariant::WardDuer;
                else if (variant == "balanced") b.ward_variant = WardVariant::Balanced;
                else fail(src, find(p, "variant")->line, "ward variant must be ward, ward-duer or balanced, not " + quote(variant));
                anisotropic_alpha(p, tex, &b);
                b.diffuse = spectrum_param(p, tex, "diffuseReflectance", RGB(0.5f), &b.tex_diffuse);
                b.specular = spectrum_param(p, tex, "specularReflectance", RGB(0.2f), &b.tex_specular);
            } else {
                fail(src, p.line, "unsupported bsdf type " + quote(t));
            }
            for (const auto& [name, tp] : tex)
                if (!tp.used)
                    fail(src, tp.line, "parameter " + quote(name) + " of " + p.what() +
                                           (find(p, name) || known_constant_param(t, name)
                                                ? " cannot be a texture in iris (only reflectances, transmittance and roughness can)"
                                                : " is unknown (a texture was given for it)"));
        }
        finish(p, ignore);
        check_bsdf(p, b);
        if (!p.id.empty()) {
            NamedBsdf nb;
            nb.bsdf = b;
            nb.src = &src;
            nb.line = p.line;
            named_bsdfs_[p.id] = nb;
        }
        if (id_out) *id_out = p.id;
        if (line_out) *line_out = p.line;
        return b;
    }

    void check_bsdf(const Plugin& p, const Bsdf& b) {
        for (const RGB* c : {&b.diffuse, &b.specular, &b.transmittance, &b.eta, &b.k})
            if (!is_finite(*c) || c->r < 0 || c->g < 0 || c->b < 0)
                fail(*p.src, p.line, p.what() + ": colours and IORs must be finite and non-negative");
    }

    float alpha_param(Plugin& p, const std::string& name, float def) {
        float a = get_float(p, name, def);
        if (a < 0) fail(*p.src, find(p, name)->line, name + " must not be negative");
        // Mitsuba clamps roughness to 1e-4: smaller values are numerically a mirror.
        return std::max(a, 1e-4f);
    }
    // The same, or a texture (its mean over R, G, B at the hit: Bsdf::tex_alpha_*).
    float alpha_param(Plugin& p, TexParams& tex, const std::string& name, float def, int16_t* tex_index) {
        auto it = tex.find(name);
        if (it == tex.end()) return alpha_param(p, name, def);
        it->second.used = true;
        *tex_index = it->second.index;
        return def;
    }

    // Roughness as Mitsuba's microfacet models take it: either `alpha` (isotropic) or both `alphaU`
    // and `alphaV`; default 0.1. Each may be a texture.
    void anisotropic_alpha(Plugin& p, TexParams& tex, Bsdf* b) {
        auto line_of = [&](const char* n) { return find(p, n) ? find(p, n)->line : tex.at(n).line; };
        const bool has_a = find(p, "alpha") || tex.count("alpha"), has_u = find(p, "alphaU") || tex.count("alphaU"),
                   has_v = find(p, "alphaV") || tex.count("alphaV");
        if (has_a && (has_u || has_v)) fail(*p.src, line_of("alpha"), "give either alpha or alphaU/alphaV");
        if (has_u != has_v) fail(*p.src, line_of(has_u ? "alphaU" : "alphaV"), "alphaU and alphaV must be given together");
        if (has_u) {
            b->alpha_u = alpha_param(p, tex, "alphaU", 0.1f, &b->tex_alpha_u);
            b->alpha_v = alpha_param(p, tex, "alphaV", 0.1f, &b->tex_alpha_v);
        } else {
            b->alpha_u = b->alpha_v = alpha_param(p, tex, "alpha", 0.1f, &b->tex_alpha_u);
            b->tex_alpha_v = b->tex_alpha_u;
        }
    }

    // ---- textures -------------------------------------------------------------------------------
    // Mitsuba's textures on BSDF parameters: `bitmap` (an image file), `checkerboard`, and `scale` (a
    // texture times a constant), nested in the BSDF (<texture name="reflectance" ...>) or declared at
    // the top level with an id and referenced (<ref name="reflectance" id="..."/>). Each distinct
    // texture becomes one Scene::textures entry: repeated references share it, and an image file is
    // decoded (and fingerprinted) once however many textures read it.

    // Parameters the BSDF plugins take as constants only (a texture for one is refused by name).
    static bool known_constant_param(const std::string& type, const std::string& name) {
        static const char* const kNames[] = {"intIOR", "extIOR", "eta", "k", "extEta", "material", "distribution",
                                             "nonlinear", "variant", "useFastApprox", "sampleVisible"};
        (void)type;
        return std::find(std::begin(kNames), std::end(kNames), name) != std::end(kNames);
    }

    // The BSDF's nested <texture> and <ref> children, by the parameter each gives.
    TexParams bsdf_textures(Plugin& p) {
        TexParams out;
        const Source& src = *p.src;
        for (pugi::xml_node c : p.children) {
            const std::string tag = c.name();
            const int line = src.line_of(c);
            if (tag != "texture" && tag != "ref") fail(src, line, "<" + tag + "> is not allowed inside " + p.what());
            const std::optional<std::string> name = opt_attr(src, c, "name");
            if (!name || name->empty())
                fail(src, line, "a <" + tag + "> inside " + p.what() + " needs a name (the parameter it gives)");
            if (Prop* prop = find(p, *name))
                fail(src, line, "parameter " + quote(*name) + " given twice (first at line " + std::to_string(prop->line) + ")");
            if (auto it = out.find(*name); it != out.end())
                fail(src, line, "parameter " + quote(*name) + " given twice (first at line " + std::to_string(it->second.line) + ")");
            TexParam tp;
            tp.line = line;
            tp.index = tag == "texture" ? parse_texture(src, c, "texture for parameter " + quote(*name) + " of " + p.what())
                                        : texture_ref(src, c);
            out[*name] = tp;
        }
        return out;
    }

    // A constant or textured colour parameter: the constant (or `def`) with *tex_index = -1, or
    // `def` with *tex_index naming the texture.
    RGB spectrum_param(Plugin& p, TexParams& tex, const std::string& name, RGB def, int16_t* tex_index) {
        auto it = tex.find(name);
        if (it == tex.end()) return get_spectrum(p, name, def);
        it->second.used = true;
        *tex_index = it->second.index;
        return def;
    }

    void top_level_texture(const Source& src, pugi::xml_node n) {
        const int line = src.line_of(n);
        const std::string id = opt_attr(src, n, "id").value_or("");
        parse_texture(src, n, "texture", true);
        if (id.empty()) warn(src, line, "a top-level texture without an id can never be used");
    }

    // <ref id=...> to a texture declared earlier.
    int16_t texture_ref(const Source& src, pugi::xml_node n) {
        check_attrs(src, n, {"id", "name"});
        check_no_text(src, n);
        const int line = src.line_of(n);
        const std::string id = attr(src, n, "id");
        auto it = named_textures_.find(id);
        if (it == named_textures_.end()) {
            auto known = ids_.find(id);
            if (known != ids_.end())
                fail(src, line, "<ref id=" + quote(id) + "> refers to a <" + known->second.tag + ">, not to a texture");
            fail(src, line, "undefined reference " + quote(id) + " (a texture must be declared before it is referenced)");
        }
        it->second.used = true;
        return it->second.index;
    }

    // Texture coordinates' scale and offset, as Mitsuba's Texture2D reads them (uvscale sets both scales).
    void uv_transform(Plugin& p, Texture* t) {
        const float uv = get_float(p, "uvscale", 1.0f);
        t->uscale = get_float(p, "uscale", uv);
        t->vscale = get_float(p, "vscale", uv);
        t->uoffset = get_float(p, "uoffset", 0.0f);
        t->voffset = get_float(p, "voffset", 0.0f);
    }

    WrapMode wrap_mode(Plugin& p, const std::string& name, WrapMode def) {
        std::optional<std::string> w = get_string(p, name);
        if (!w) return def;
        const std::string v = lower(*w);
        if (v == "repeat") return WrapMode::Repeat;
        if (v == "mirror") return WrapMode::Mirror;
        if (v == "clamp") return WrapMode::Clamp;
        if (v == "zero") return WrapMode::Zero;
        if (v == "one") return WrapMode::One;
        fail(*p.src, find(p, name)->line, name + " must be repeat, mirror, clamp, zero or one, not " + quote(*w));
    }

    int16_t add_texture(Texture t, const std::string& key) {
        if (auto it = texture_by_key_.find(key); it != texture_by_key_.end()) return it->second;
        if (scene_.textures.size() >= size_t(INT16_MAX))
            throw SceneError("more than " + std::to_string(INT16_MAX) + " distinct textures");
        scene_.textures.push_back(std::move(t));
        const int16_t i = int16_t(scene_.textures.size() - 1);
        texture_by_key_.emplace(key, i);
        return i;
    }

    static std::string key_of(const Texture& t) {
        char b[160];
        std::snprintf(b, sizeof b, "|%d|%d|%d|%a|%a|%a|%a|%a|%a|%a|%a|%a|%a", int(t.wrap_u), int(t.wrap_v),
                      int(t.filter), t.uscale, t.vscale, t.uoffset, t.voffset, t.color0.r, t.color0.g, t.color0.b,
                      t.color1.r, t.color1.g, t.color1.b);
        return b;
    }

    // A <texture> element -> index into scene_.textures. `context` names where it stands, for messages.
    int16_t parse_texture(const Source& src, pugi::xml_node n, const std::string& context, bool top_level = false) {
        Plugin p = read_plugin(src, n);
        int16_t index = -1;
        if (p.type == "bitmap") {
            no_children(p);
            std::optional<std::string> file = get_string(p, "filename");
            if (!file) fail(src, p.line, "texture \"bitmap\" needs a filename");
            const int fline = find(p, "filename")->line;
            BitmapOptions o;
            o.gamma = get_float(p, "gamma", 0.0f);
            if (!(o.gamma == 0.0f || o.gamma == -1.0f || o.gamma > 0.0f))
                fail(src, find(p, "gamma")->line, "gamma must be 0 (automatic), -1 (sRGB) or positive");
            o.channel = lower(get_string(p, "channel", ""));
            const std::string filter = lower(get_string(p, "filterType", "ewa"));
            if (filter == "nearest") o.filter = TextureFilter::Nearest;
            else if (filter == "ewa" || filter == "trilinear") o.filter = TextureFilter::Bilinear;
            else fail(src, find(p, "filterType")->line, "filterType must be ewa, trilinear or nearest, not " + quote(filter));
            if (Prop* f = find(p, "filterType"); f && filter != "nearest")
                warn(src, f->line, "filterType " + quote(filter) + " read as bilinear: iris has no MIP-map filtering "
                                   "(pixel averages converge to the same values, with more noise where a texture is minified)");
            const WrapMode both = wrap_mode(p, "wrapMode", WrapMode::Repeat);
            o.wrap_u = wrap_mode(p, "wrapModeU", both);
            o.wrap_v = wrap_mode(p, "wrapModeV", both);
            Texture shape;
            uv_transform(p, &shape);
            o.uscale = shape.uscale;
            o.vscale = shape.vscale;
            o.uoffset = shape.uoffset;
            o.voffset = shape.voffset;
            finish(p, [](const std::string& name) -> const char* {
                if (name == "maxAnisotropy") return "it tunes EWA filtering, which iris does not do";
                if (name == "cache") return "Mitsuba's MIP-map cache switch; iris builds no MIP maps";
                return nullptr;
            });
            const fs::path path = resolve(src, *file);
            const std::string decode_key = path.lexically_normal().string() + "|" + std::to_string(o.gamma) + "|" + o.channel;
            Texture t;
            if (auto it = decoded_by_file_.find(decode_key); it != decoded_by_file_.end()) {
                t = scene_.textures[size_t(it->second)];  // the same texels, perhaps sampled differently
            } else {
                std::string bytes;
                if (!read_file(path, &bytes))
                    fail(src, fline, "cannot read texture file " + quote(*file) + " (resolved to " + path.string() + ")");
                if (!hashed_files_.count(path.lexically_normal().string())) {
                    fingerprint_.add(bytes);
                    hashed_files_.insert(path.lexically_normal().string());
                }
                bytes = std::string();
                try {
                    t = load_bitmap_texture(path.string(), o);
                } catch (const std::exception& e) {
                    fail(src, fline, "texture " + quote(*file) + ": " + e.what());
                }
                if (t.width <= 0 || t.height <= 0 || t.texels.empty())
                    fail(src, fline, "texture " + quote(*file) + " has no pixels (" + std::to_string(t.width) + " x " +
                                         std::to_string(t.height) + ")");
                for (size_t i = 0; i < t.texels.size(); ++i) {
                    const RGB c = t.texels[i];
                    if (!is_finite(c) || c.r < 0 || c.g < 0 || c.b < 0)
                        fail(src, fline, "texture " + quote(*file) + " has a negative or non-finite value at pixel (" +
                                             std::to_string(i % size_t(t.width)) + ", " + std::to_string(i / size_t(t.width)) +
                                             "); BSDF parameters must be finite and non-negative");
                }
            }
            set_bitmap_sampling(o, &t);  // a shared decoded file may be sampled differently
            const bool fresh = !decoded_by_file_.count(decode_key);
            index = add_texture(std::move(t), "bitmap|" + decode_key + texture_options_key(o));
            if (fresh) decoded_by_file_.emplace(decode_key, index);
        } else if (p.type == "checkerboard") {
            no_children(p);
            Texture t;
            t.type = TextureType::Checkerboard;
            t.color0 = get_spectrum(p, "color0", RGB(0.4f));
            t.color1 = get_spectrum(p, "color1", RGB(0.2f));
            for (const RGB* c : {&t.color0, &t.color1})
                if (!is_finite(*c) || c->r < 0 || c->g < 0 || c->b < 0)
                    fail(src, p.line, "checkerboard colours must be finite and non-negative");
            uv_transform(p, &t);
            finish(p);
            const std::string key = "checkerboard" + key_of(t);
            index = add_texture(std::move(t), key);
        } else if (p.type == "scale") {
            // Mitsuba's `scale`: a nested texture times `scale` (a number or a colour), baked into the texels.
            if (p.children.size() != 1)
                fail(src, p.line, "texture \"scale\" needs exactly one nested <texture> or <ref>");
            pugi::xml_node c = p.children[0];
            const std::string tag = c.name();
            int16_t inner = -1;
            if (tag == "texture") inner = parse_texture(src, c, context);
            else if (tag == "ref") inner = texture_ref(src, c);
            else fail(src, src.line_of(c), "<" + tag + "> is not allowed inside texture \"scale\"");
            RGB k(1.0f);
            if (Prop* sp = find(p, "scale"); sp && (sp->kind == Kind::Float || sp->kind == Kind::Integer))
                k = RGB(*get_float(p, "scale"));
            else
                k = get_spectrum(p, "scale", RGB(1.0f));
            if (!is_finite(k) || k.r < 0 || k.g < 0 || k.b < 0)
                fail(src, find(p, "scale")->line, "the scale of texture \"scale\" must be finite and non-negative");
            finish(p);
            Texture t = scene_.textures[size_t(inner)];
            for (RGB& v : t.texels) v = v * k;
            t.color0 = t.color0 * k;
            t.color1 = t.color1 * k;
            char b[96];
            std::snprintf(b, sizeof b, "scale|%d|%a|%a|%a", int(inner), k.r, k.g, k.b);
            index = add_texture(std::move(t), b);
        } else {
            fail(src, p.line, "unsupported plugin " + quote(p.type) + " (" + context +
                                  "; iris reads bitmap, checkerboard and scale textures)");
        }
        if (!p.id.empty()) {
            NamedTexture nt;
            nt.index = index;
            nt.src = &src;
            nt.line = p.line;
            nt.used = !top_level;  // a nested texture is used where it stands
            named_textures_[p.id] = nt;
        }
        return index;
    }

    static std::string texture_options_key(const BitmapOptions& o) {
        char b[128];
        std::snprintf(b, sizeof b, "|%d|%d|%d|%a|%a|%a|%a", int(o.filter), int(o.wrap_u), int(o.wrap_v), o.uscale,
                      o.vscale, o.uoffset, o.voffset);
        return b;
    }

    Microfacet distribution(Plugin& p) {
        std::string d = lower(get_string(p, "distribution", "beckmann"));
        if (d == "beckmann") return Microfacet::Beckmann;
        if (d == "ggx") return Microfacet::GGX;
        const int line = find(p, "distribution")->line;
        if (d == "phong" || d == "as")
            fail(*p.src, line, "microfacet distribution " + quote(d) + " is unsupported (beckmann or ggx)");
        fail(*p.src, line, "unknown microfacet distribution " + quote(d) + " (beckmann or ggx)");
    }

    // A <ref id=...> to a BSDF declared earlier.
    NamedBsdf& named_bsdf(const Source& src, pugi::xml_node n) {
        check_attrs(src, n, {"id", "name"});
        check_no_text(src, n);
        const int line = src.line_of(n);
        std::string id = attr(src, n, "id");
        if (auto name = opt_attr(src, n, "name"); name && *name != "bsdf")
            fail(src, line, "<ref name=" + quote(*name) + ">: only BSDF references are supported");
        auto it = named_bsdfs_.find(id);
        if (it == named_bsdfs_.end()) {
            auto known = ids_.find(id);
            if (known != ids_.end())
                fail(src, line, "<ref id=" + quote(id) + "> refers to a <" + known->second.tag + ">, not to a bsdf");
            fail(src, line, "undefined reference " + quote(id) + " (a bsdf must be declared before it is referenced)");
        }
        it->second.used = true;
        return it->second;
    }

    uint32_t add_bsdf(const Bsdf& b) {
        scene_.bsdfs.push_back(b);
        return uint32_t(scene_.bsdfs.size() - 1);
    }

    // ---- shapes ---------------------------------------------------------------------------------
    void shape(const Source& src, pugi::xml_node n) {
        Plugin p = read_plugin(src, n);
        if (p.type == "shapegroup") return shape_group(p);
        if (p.type == "instance") return instance(p);
        std::optional<uint32_t> bsdf;
        pugi::xml_node emitter_node;
        for (pugi::xml_node c : p.children) {
            std::string tag = c.name();
            if (tag == "bsdf" || tag == "ref") {
                if (bsdf) fail(src, src.line_of(c), "a shape has one bsdf; this is a second one");
                if (tag == "bsdf") {
                    std::string id;
                    Bsdf b = parse_bsdf(src, c, &id);
                    bsdf = add_bsdf(b);
                    if (!id.empty()) {
                        named_bsdfs_[id].index = int(*bsdf);
                        named_bsdfs_[id].used = true;
                    }
                } else {
                    NamedBsdf& nb = named_bsdf(src, c);
                    if (nb.index < 0) nb.index = int(add_bsdf(nb.bsdf));
                    bsdf = uint32_t(nb.index);
                }
            } else if (tag == "emitter") {
                if (emitter_node) fail(src, src.line_of(c), "a shape can carry one emitter; this is a second one");
                emitter_node = c;
            } else if (tag == "medium" || tag == "subsurface") {
                fail(src, src.line_of(c), "<" + tag + "> on shapes is not supported (no participating media in iris)");
            } else {
                fail(src, src.line_of(c), "<" + tag + "> is not allowed inside a shape");
            }
        }
        if (!bsdf) {
            // Mitsuba's default: diffuse, reflectance 0.5. One shared instance.
            if (default_bsdf_ < 0) default_bsdf_ = int(add_bsdf(Bsdf()));
            bsdf = uint32_t(default_bsdf_);
        }

        const std::string& t = p.type;
        const bool flip = get_bool(p, "flipNormals", false);
        IgnoreRule ignore;
        LightType light_type = LightType::AreaMesh;
        uint32_t shape_index = 0;
        if (t == "sphere") {
            Sphere s;
            Vec3 center = get_point(p, "center").value_or(Vec3(0.0f));
            float radius = get_float(p, "radius", 1.0f);
            if (!(radius > 0)) fail(src, p.line, "sphere radius must be positive");
            if (auto m = get_transform(p, "toWorld")) {
                // Mitsuba: toWorld * translate(center) * scale(radius); only a similarity keeps it a sphere.
                Vec3 ax = m->vector(Vec3(1, 0, 0)), ay = m->vector(Vec3(0, 1, 0)), az = m->vector(Vec3(0, 0, 1));
                float lx = length(ax), ly = length(ay), lz = length(az);
                float tol = 1e-4f * std::max(lx, std::max(ly, lz));
                if (std::abs(lx - ly) > tol || std::abs(lx - lz) > tol || std::abs(dot(ax, ay)) > tol * lx ||
                    std::abs(dot(ax, az)) > tol * lx || std::abs(dot(ay, az)) > tol * lx)
                    fail(src, find(p, "toWorld")->line, "a sphere's toWorld must scale uniformly (no shear)");
                center = m->point(center);
                radius *= lx;
                s.axis_x = ax / lx;  // the uv parameterization's frame (Scene::intersect)
                s.axis_y = ay / ly;
                s.axis_z = az / lz;
            }
            // As for mesh vertices: a transform can push a valid sphere out of float range.
            if (!is_finite(center) || !(radius > 0) || !std::isfinite(radius))
                fail(src, p.line, "sphere centre or radius is not finite (or zero) after toWorld");
            s.center = center;
            s.radius = radius;
            s.bsdf = *bsdf;
            s.flip_normals = flip;
            scene_.spheres.push_back(s);
            shape_index = uint32_t(scene_.spheres.size() - 1);
            light_type = LightType::AreaSphere;
        } else {
            Mesh mesh;
            mesh.name = p.id;
            Transform to_world = get_transform(p, "toWorld").value_or(Transform());
            if (t == "obj") {
                Prop* fprop = find(p, "filename");
                std::optional<std::string> file = get_string(p, "filename");
                if (!file) fail(src, p.line, "shape \"obj\" needs a filename");
                if (mesh.name.empty()) mesh.name = *file;
                const bool face_normals = get_bool(p, "faceNormals", false);
                const bool flip_tex = get_bool(p, "flipTexCoords", true);
                load_obj(src, fprop->line, *file, to_world, face_normals, flip_tex, &mesh);
                if (Prop* m = find(p, "maxSmoothAngle"))
                    fail(src, m->line, "maxSmoothAngle is not supported (give normals in the OBJ or use faceNormals)");
            } else if (t == "rectangle") {
                // Mitsuba: [-1,1]^2 in the z = 0 plane, facing +z.
                if (mesh.name.empty()) mesh.name = "rectangle";
                std::vector<Vec3> pos = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
                std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3};
                build_mesh(src, p.line, pos, {}, idx, to_world, &mesh);
                mesh.uvs = {Vec2{0, 0}, Vec2{1, 0}, Vec2{1, 1}, Vec2{0, 1}};  // as Mitsuba's rectangle
            } else if (t == "cube") {
                // Mitsuba's cube: [-1,1]^3, flat faces, each face mapped onto [0,1]^2 in uv. Its corners
                // in Mitsuba's order (faces -y, +y, +x, +z, -x, -z; triangles (0,1,2), (3,0,2) per face,
                // counter-clockwise seen from outside), each face's four corners at uv (0,1), (1,1),
                // (1,0), (0,0), so that a texture lands on every face as in Mitsuba.
                if (mesh.name.empty()) mesh.name = "cube";
                static const signed char kCorners[24][3] = {
                    {1, -1, -1}, {1, -1, 1},  {-1, -1, 1}, {-1, -1, -1}, {1, 1, -1},  {-1, 1, -1}, {-1, 1, 1},  {1, 1, 1},
                    {1, -1, -1}, {1, 1, -1},  {1, 1, 1},   {1, -1, 1},   {1, -1, 1},  {1, 1, 1},   {-1, 1, 1},  {-1, -1, 1},
                    {-1, -1, 1}, {-1, 1, 1},  {-1, 1, -1}, {-1, -1, -1}, {1, 1, -1},  {1, -1, -1}, {-1, -1, -1}, {-1, 1, -1}};
                static const Vec2 kFaceUv[4] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
                std::vector<Vec3> pos;
                std::vector<Vec2> uv;
                std::vector<uint32_t> idx;
                for (int i = 0; i < 24; ++i) {
                    pos.push_back(Vec3(kCorners[i][0], kCorners[i][1], kCorners[i][2]));
                    uv.push_back(kFaceUv[i % 4]);
                }
                for (uint32_t f = 0; f < 6; ++f)
                    for (uint32_t k : {0u, 1u, 2u, 3u, 0u, 2u}) idx.push_back(4 * f + k);
                build_mesh(src, p.line, pos, {}, idx, to_world, &mesh);
                mesh.uvs = std::move(uv);
            } else if (t == "disk") {
                // Mitsuba: the unit disk in the z = 0 plane, facing +z. Tessellated (kDiskSegments
                // triangles) with the radius chosen so that the polygon's area is exactly pi, so that
                // an emitting disk sends out Mitsuba's power; the rim lies within 1.6e-5 of the
                // circle, relative to the radius.
                if (mesh.name.empty()) mesh.name = "disk";
                constexpr int kDiskSegments = 512;
                const double step = 2 * double(kPi) / kDiskSegments;
                const double r = std::sqrt(double(kPi) / (0.5 * kDiskSegments * std::sin(step)));
                // uv = Mitsuba's (radius, angle / 2 pi). Linear interpolation over a fan cannot give the
                // angle near the centre from one centre vertex, nor cross the seam at angle 0 = 1: so each
                // segment has its own centre vertex at its mid-angle, and the rim vertex closing the last
                // segment is a copy of the first at v = 1. The angle is then off by at most half a
                // segment (1 / 1024) near the centre and exact on the rim.
                std::vector<Vec3> pos;
                std::vector<Vec2> uv;
                std::vector<uint32_t> idx;
                for (int i = 0; i <= kDiskSegments; ++i) {
                    const int k = i % kDiskSegments;  // the same position for i = 0 and i = kDiskSegments
                    pos.push_back(Vec3(float(r * std::cos(k * step)), float(r * std::sin(k * step)), 0.0f));
                    uv.push_back(Vec2{1.0f, float(i) / kDiskSegments});
                }
                for (int i = 0; i < kDiskSegments; ++i) {
                    pos.push_back(Vec3(0.0f));
                    uv.push_back(Vec2{0.0f, (float(i) + 0.5f) / kDiskSegments});
                    idx.insert(idx.end(), {uint32_t(pos.size() - 1), uint32_t(i), uint32_t(i + 1)});
                }
                build_mesh(src, p.line, pos, {}, idx, to_world, &mesh);
                mesh.uvs = std::move(uv);
            } else if (t == "ply" || t == "serialized") {
                Prop* fprop = find(p, "filename");
                std::optional<std::string> file = get_string(p, "filename");
                if (!file) fail(src, p.line, "shape " + quote(t) + " needs a filename");
                if (mesh.name.empty()) mesh.name = *file;
                const bool face_normals = get_bool(p, "faceNormals", false);
                uint32_t shape_index = 0;
                if (t == "serialized") {
                    const int si = get_int(p, "shapeIndex", 0);
                    if (si < 0) fail(src, find(p, "shapeIndex")->line, "shapeIndex must not be negative");
                    shape_index = uint32_t(si);
                }
                if (Prop* m = find(p, "maxSmoothAngle"))
                    fail(src, m->line, "maxSmoothAngle is not supported (give normals in the mesh or use faceNormals)");
                load_binary_mesh(src, fprop->line, t, *file, shape_index, to_world, face_normals, &mesh);
                ignore = [](const std::string& name) -> const char* {
                    if (name == "srgb") return "it concerns vertex colours, which iris does not use";
                    return nullptr;
                };
            } else {
                fail(src, p.line, "unsupported shape type " + quote(t) +
                                      " (supported: obj, ply, serialized, sphere, rectangle, disk, cube, shapegroup, instance)");
            }
            mesh.bsdf = *bsdf;
            mesh.flip_normals = flip;
            scene_.meshes.push_back(std::move(mesh));
            shape_index = uint32_t(scene_.meshes.size() - 1);
        }
        finish(p, ignore);

        if (emitter_node) {
            Plugin e = read_plugin(src, emitter_node);
            if (e.type != "area") fail(src, e.line, "only area emitters can be attached to a shape, not " + quote(e.type));
            no_children(e);
            Light l;
            l.type = light_type;
            l.shape = shape_index;
            l.radiance = get_spectrum(e, "radiance", RGB(1.0f));
            l.sampling_weight = sampling_weight(e);
            check_radiance(e, l.radiance);
            finish(e);
            scene_.lights.push_back(l);
            const int32_t li = int32_t(scene_.lights.size() - 1);
            if (light_type == LightType::AreaSphere) scene_.spheres[shape_index].light = li;
            else scene_.meshes[shape_index].light = li;
        }
    }

    float sampling_weight(Plugin& e) {
        float w = get_float(e, "samplingWeight", 1.0f);
        if (!(w > 0)) fail(*e.src, find(e, "samplingWeight")->line, "samplingWeight must be positive");
        return w;
    }

    void check_radiance(const Plugin& e, RGB c) {
        if (!is_finite(c) || c.r < 0 || c.g < 0 || c.b < 0)
            fail(*e.src, e.line, e.what() + ": emission must be finite and non-negative");
    }

    // Reads an OBJ file into `mesh` (world space). Mesh errors name the XML line of the filename.
    // Texture coordinates as Mitsuba 0.5/0.6's OBJ loader reads them: with flipTexCoords (its default,
    // true) v' = 1 - v, since OBJ's v = 0 is the image's bottom row and Mitsuba's texture lookup has
    // v = 0 at the top; without it, as written. Used when every face corner has one; otherwise none.
    void load_obj(const Source& src, int line, const std::string& file, const Transform& to_world, bool face_normals,
                  bool flip_tex, Mesh* mesh) {
        fs::path path = resolve(src, file);
        std::string text;
        if (!read_file(path, &text))
            fail(src, line, "cannot read mesh file " + quote(file) + " (resolved to " + path.string() + ")");
        fingerprint_.add(text);
        ObjMesh obj;
        try {
            obj = parse_obj(text, path.string());
        } catch (const ObjError& e) {
            fail(src, line, "in mesh " + quote(file) + ": " + e.what());
        }
        if (obj.face_sizes.empty()) fail(src, line, "mesh " + quote(file) + " has no faces");

        // Normals are usable when every corner has one; Mitsuba computes them otherwise.
        bool use_normals = !face_normals && !obj.normals.empty();
        if (use_normals) {
            size_t missing = 0;
            for (const ObjMesh::Corner& c : obj.corners) missing += c.n < 0;
            if (missing) {
                warn(src, line, "mesh " + quote(file) + ": " + std::to_string(missing) +
                                    " face corners have no normal; computing smooth normals for the whole mesh");
                use_normals = false;
            }
        }

        bool use_uvs = !obj.texcoords.empty();
        if (use_uvs) {
            size_t missing = 0;
            for (const ObjMesh::Corner& c : obj.corners) missing += c.t < 0;
            if (missing) {
                warn(src, line, "mesh " + quote(file) + ": " + std::to_string(missing) +
                                    " face corners have no texture coordinate; the mesh gets none (a texture reads each triangle's barycentrics, as in Mitsuba)");
                use_uvs = false;
            }
        }

        // One vertex per distinct (position, normal, texture coordinate), as Mitsuba's OBJ loader does.
        struct Key {
            uint32_t v;
            int32_t n, t;
            bool operator==(const Key& o) const { return v == o.v && n == o.n && t == o.t; }
        };
        struct KeyHash {
            size_t operator()(const Key& k) const {
                return size_t((uint64_t(k.v) * 0x9e3779b97f4a7c15ULL) ^ (uint64_t(uint32_t(k.n)) * 0xc2b2ae3d27d4eb4fULL) ^
                              (uint64_t(uint32_t(k.t)) * 0x165667b19e3779f9ULL));
            }
        };
        std::unordered_map<Key, uint32_t, KeyHash> remap;
        remap.reserve(obj.corners.size());
        std::vector<Vec3> pos, nrm;
        std::vector<Vec2> uv;
        std::vector<uint32_t> corner_vertex(obj.corners.size());
        for (size_t i = 0; i < obj.corners.size(); ++i) {
            const ObjMesh::Corner& c = obj.corners[i];
            const Key key{c.v, use_normals ? c.n : -1, use_uvs ? c.t : -1};
            auto [it, inserted] = remap.emplace(key, uint32_t(pos.size()));
            if (inserted) {
                pos.push_back(obj.positions[c.v]);
                if (use_normals) nrm.push_back(obj.normals[size_t(c.n)]);
                if (use_uvs) {
                    Vec2 t = obj.texcoords[size_t(c.t)];
                    if (flip_tex) t.y = 1.0f - t.y;
                    uv.push_back(t);
                }
            }
            corner_vertex[i] = it->second;
        }
        // Polygons become triangle fans (0, i, i+1), as in Mitsuba's OBJ loader.
        std::vector<uint32_t> idx;
        idx.reserve(3 * obj.corners.size());
        for (size_t f = 0, c = 0; f < obj.face_sizes.size(); c += obj.face_sizes[f], ++f)
            for (uint32_t i = 1; i + 1 < obj.face_sizes[f]; ++i) {
                idx.push_back(corner_vertex[c]);
                idx.push_back(corner_vertex[c + i]);
                idx.push_back(corner_vertex[c + i + 1]);
            }
        build_mesh(src, line, pos, nrm, idx, to_world, mesh, face_normals, file);
        mesh->uvs = std::move(uv);
    }

    // Reads a PLY or Mitsuba serialized mesh into `mesh` (world space). Errors name the XML line of
    // the filename and the mesh file. Normals: the file's, unless flat shading is asked for (the
    // faceNormals parameter, or serialized's face-normal flag); none in the file = computed smooth
    // ones, as Mitsuba does.
    void load_binary_mesh(const Source& src, int line, const std::string& type, const std::string& file, uint32_t index,
                          const Transform& to_world, bool face_normals, Mesh* mesh) {
        fs::path path = resolve(src, file);
        std::string bytes;
        if (!read_file(path, &bytes))
            fail(src, line, "cannot read mesh file " + quote(file) + " (resolved to " + path.string() + ")");
        fingerprint_.add(bytes);
        if (type == "serialized") fingerprint_.add(std::to_string(index));
        TriangleMesh tm;
        try {
            tm = type == "ply" ? parse_ply(bytes, path.string()) : parse_serialized(bytes, index, path.string());
        } catch (const MeshFileError& e) {
            fail(src, line, "in " + type + " mesh " + quote(file) + ": " + e.what());
        }
        bytes = std::string();  // the file's bytes are no longer needed: free them before the world-space copy
        const bool flat = face_normals || tm.face_normals;
        if (flat) tm.normals.clear();
        build_mesh(src, line, tm.positions, tm.normals, tm.indices, to_world, mesh, flat, file);
        mesh->uvs = std::move(tm.uvs);
    }

    // ---- shapegroups and instances ----------------------------------------------------------------
    // A shapegroup's shapes, in the group's own space, kept aside until instances place them.
    //
    // Instances are flattened: each one is a world-space copy of the group's triangles, so memory
    // grows with instances x triangles (12 bytes a vertex, 12 a normal, 8 a uv, 12 a triangle). Embree
    // instancing (RTC_GEOMETRY_TYPE_INSTANCE) would share the BVH and the vertices, but Scene::intersect,
    // the light samplers and photon emission address world-space Mesh arrays by geometry ID; sharing
    // would need instance transforms in each of them. Flattening gives exactly the triangles of explicit
    // copies (tests/unit/test_mesh_formats.cpp checks this), which is what matters for correctness.
    struct ShapeGroup {
        std::vector<Mesh> meshes;
        std::vector<Sphere> spheres;
    };

    void shape_group(Plugin& p) {
        const Source& src = *p.src;
        if (p.id.empty()) fail(src, p.line, "a shapegroup needs an id (instances refer to it)");
        if (in_group_) fail(src, p.line, "shapegroups cannot be nested (Mitsuba does not allow it either)");
        const size_t m0 = scene_.meshes.size(), s0 = scene_.spheres.size();
        in_group_ = true;
        for (pugi::xml_node c : p.children) {
            const std::string tag = c.name();
            if (tag != "shape") fail(src, src.line_of(c), "<" + tag + "> is not allowed inside a shapegroup (only <shape>s)");
            if (pugi::xml_node e = c.child("emitter"))
                fail(src, src.line_of(e),
                     "an area emitter inside a shapegroup is not supported (nor in Mitsuba); attach it to a shape outside");
            shape(src, c);
        }
        in_group_ = false;
        finish(p);
        ShapeGroup g;
        g.meshes.assign(std::make_move_iterator(scene_.meshes.begin() + ptrdiff_t(m0)),
                        std::make_move_iterator(scene_.meshes.end()));
        g.spheres.assign(scene_.spheres.begin() + ptrdiff_t(s0), scene_.spheres.end());
        scene_.meshes.resize(m0);
        scene_.spheres.resize(s0);
        if (g.meshes.empty() && g.spheres.empty()) fail(src, p.line, "shapegroup " + quote(p.id) + " has no shapes");
        groups_[p.id] = std::move(g);
    }

    void instance(Plugin& p) {
        const Source& src = *p.src;
        if (in_group_) fail(src, p.line, "an instance inside a shapegroup is not supported");
        pugi::xml_node ref;
        for (pugi::xml_node c : p.children) {
            if (std::string_view(c.name()) != "ref")
                fail(src, src.line_of(c), "<" + std::string(c.name()) + "> is not allowed inside an instance (only a <ref> to a shapegroup)");
            if (ref) fail(src, src.line_of(c), "an instance refers to one shapegroup; this is a second <ref>");
            ref = c;
        }
        if (!ref) fail(src, p.line, "an instance needs a <ref id=\"...\"/> to a shapegroup");
        check_attrs(src, ref, {"id", "name"});
        check_no_text(src, ref);
        const std::string id = attr(src, ref, "id");
        auto it = groups_.find(id);
        if (it == groups_.end()) {
            auto known = ids_.find(id);
            if (known != ids_.end())
                fail(src, src.line_of(ref), "<ref id=" + quote(id) + "> refers to a <" + known->second.tag + ">, not to a shapegroup");
            fail(src, src.line_of(ref), "undefined shapegroup " + quote(id) + " (it must be declared before its instances)");
        }
        const Transform m = get_transform(p, "toWorld").value_or(Transform());
        finish(p);
        const ShapeGroup& g = it->second;
        for (const Mesh& gm : g.meshes) {
            Mesh out;
            out.name = gm.name + " (instance of " + quote(id) + ")";
            // The group's normals (given or computed) are transformed; flat meshes stay flat.
            build_mesh(src, p.line, gm.positions, gm.normals, gm.indices, m, &out);
            out.uvs = gm.uvs;
            out.bsdf = gm.bsdf;
            out.flip_normals = gm.flip_normals;
            scene_.meshes.push_back(std::move(out));
        }
        for (Sphere s : g.spheres) {
            Vec3 ax = m.vector(Vec3(1, 0, 0)), ay = m.vector(Vec3(0, 1, 0)), az = m.vector(Vec3(0, 0, 1));
            float lx = length(ax), ly = length(ay), lz = length(az);
            float tol = 1e-4f * std::max(lx, std::max(ly, lz));
            if (std::abs(lx - ly) > tol || std::abs(lx - lz) > tol || std::abs(dot(ax, ay)) > tol * lx ||
                std::abs(dot(ax, az)) > tol * lx || std::abs(dot(ay, az)) > tol * lx)
                fail(src, p.line, "an instance of a shapegroup with a sphere must scale uniformly (no shear)");
            s.center = m.point(s.center);
            s.radius *= lx;
            // The instance's rotation composes with the sphere's own frame (its uv parameterization).
            const Vec3 fx = m.vector(s.axis_x), fy = m.vector(s.axis_y), fz = m.vector(s.axis_z);
            s.axis_x = fx / length(fx);
            s.axis_y = fy / length(fy);
            s.axis_z = fz / length(fz);
            if (!is_finite(s.center) || !(s.radius > 0) || !std::isfinite(s.radius))
                fail(src, p.line, "an instanced sphere's centre or radius is not finite after toWorld");
            scene_.spheres.push_back(s);
        }
    }

    // Transforms object-space geometry to world space and fills `mesh`: drops zero-area triangles
    // (with a warning giving their number), transforms normals with the inverse transpose, and,
    // when the mesh has none and flat shading was not asked for, computes angle-weighted vertex
    // normals (Thuermer & Wuethrich 1998), as Mitsuba does for OBJs without normals.
    void build_mesh(const Source& src, int line, const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm,
                    const std::vector<uint32_t>& idx, const Transform& to_world, Mesh* mesh, bool flat = true,
                    const std::string& what = "") {
        const std::string label = what.empty() ? "the " + mesh->name : "mesh " + quote(what);
        mesh->positions.resize(pos.size());
        for (size_t i = 0; i < pos.size(); ++i) {
            mesh->positions[i] = to_world.point(pos[i]);
            if (!is_finite(mesh->positions[i])) fail(src, line, label + ": a vertex is not finite after toWorld");
        }
        // A mirroring transform reverses the winding; restore it so that the geometric normal (from
        // the winding) stays on the side the transformed shading normals point to.
        const bool mirror = to_world.determinant3x3() < 0;
        size_t degenerate = 0;
        mesh->indices.clear();
        mesh->indices.reserve(idx.size());
        for (size_t t = 0; t + 2 < idx.size(); t += 3) {
            uint32_t a = idx[t], b = idx[t + 1], c = idx[t + 2];
            if (mirror) std::swap(b, c);
            const Vec3 &p0 = mesh->positions[a], &p1 = mesh->positions[b], &p2 = mesh->positions[c];
            // Area test in double: float cross products of long thin triangles can round to zero.
            double e1[3] = {double(p1.x) - p0.x, double(p1.y) - p0.y, double(p1.z) - p0.z};
            double e2[3] = {double(p2.x) - p0.x, double(p2.y) - p0.y, double(p2.z) - p0.z};
            double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                   cz = e1[0] * e2[1] - e1[1] * e2[0];
            if (cx == 0 && cy == 0 && cz == 0) {
                ++degenerate;
                continue;
            }
            mesh->indices.insert(mesh->indices.end(), {a, b, c});
        }
        if (degenerate)
            warn(src, line, label + ": skipped " + std::to_string(degenerate) + " degenerate (zero-area) triangle" +
                                (degenerate > 1 ? "s" : ""));
        if (mesh->indices.empty()) fail(src, line, label + " has no triangles with non-zero area");

        mesh->normals.clear();
        if (!nrm.empty()) {
            const Transform nt = to_world.inverse().transpose();
            mesh->normals.resize(nrm.size());
            for (size_t i = 0; i < nrm.size(); ++i) {
                Vec3 v = nt.vector(nrm[i]);
                float l = length(v);
                // A zero normal stays zero: the renderer then falls back on the geometric normal.
                mesh->normals[i] = l > 0 && std::isfinite(l) ? v / l : Vec3(0.0f);
            }
        } else if (!flat) {
            std::vector<Vec3> acc(mesh->positions.size(), Vec3(0.0f));
            for (size_t t = 0; t < mesh->indices.size(); t += 3) {
                const uint32_t* f = &mesh->indices[t];
                Vec3 p[3] = {mesh->positions[f[0]], mesh->positions[f[1]], mesh->positions[f[2]]};
                Vec3 fn = cross(p[1] - p[0], p[2] - p[0]);
                float fl = length(fn);
                if (!(fl > 0)) continue;
                fn = fn / fl;
                for (int k = 0; k < 3; ++k) {
                    Vec3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
                    float l1 = length(e1), l2 = length(e2);
                    if (!(l1 > 0 && l2 > 0)) continue;
                    float angle = safe_acos(dot(e1, e2) / (l1 * l2));  // interior angle at corner k
                    acc[f[k]] += fn * angle;
                }
            }
            mesh->normals.resize(acc.size());
            for (size_t i = 0; i < acc.size(); ++i) {
                float l = length(acc[i]);
                mesh->normals[i] = l > 0 ? acc[i] / l : Vec3(0.0f);
            }
        }
    }

    // ---- emitters and media ---------------------------------------------------------------------
    void emitter(const Source& src, pugi::xml_node n) {
        Plugin e = read_plugin(src, n);
        no_children(e);
        Light l;
        if (e.type == "point") {
            l.type = LightType::Point;
            std::optional<Vec3> pos = get_point(e, "position");
            std::optional<Transform> m = get_transform(e, "toWorld");
            if (pos && m) fail(src, e.line, "give either position or toWorld for a point light, not both");
            l.position = pos ? *pos : m ? m->point(Vec3(0.0f)) : Vec3(0.0f);
            l.radiance = get_spectrum(e, "intensity", RGB(1.0f));  // W/sr
        } else if (e.type == "constant") {
            l.type = LightType::Constant;
            l.radiance = get_spectrum(e, "radiance", RGB(1.0f));
        } else if (e.type == "spot") {
            l.type = LightType::Spot;
            const Transform m = get_transform(e, "toWorld").value_or(Transform());
            l.position = m.point(Vec3(0.0f));
            l.direction = light_direction(e, m.vector(Vec3(0, 0, 1)), "toWorld");
            l.radiance = get_spectrum(e, "intensity", RGB(1.0f));  // W/sr on the axis
            const float cutoff = get_float(e, "cutoffAngle", 20.0f);  // degrees, Mitsuba's defaults
            const float beam = get_float(e, "beamWidth", cutoff * 0.75f);
            if (!(cutoff > 0 && cutoff <= 180))
                fail(src, find(e, "cutoffAngle")->line, "cutoffAngle must be in (0, 180] degrees");
            if (!(beam >= 0 && beam <= cutoff)) {
                Prop* bp = find(e, "beamWidth");
                fail(src, bp ? bp->line : e.line, "beamWidth must be in [0, cutoffAngle] degrees");
            }
            l.cutoff = cutoff * (kPi / 180.0f);
            l.beam_width = beam * (kPi / 180.0f);
            l.cos_cutoff = std::cos(l.cutoff);
        } else if (e.type == "directional") {
            l.type = LightType::Directional;
            std::optional<Vec3> dir = get_point(e, "direction");
            std::optional<Transform> m = get_transform(e, "toWorld");
            if (dir && m) fail(src, e.line, "give either direction or toWorld for a directional light, not both");
            l.direction = light_direction(e, dir ? *dir : m ? m->vector(Vec3(0, 0, 1)) : Vec3(0, 0, 1),
                                          dir ? "direction" : "toWorld");
            l.radiance = get_spectrum(e, "irradiance", RGB(1.0f));  // W/m^2
        } else if (e.type == "envmap") {
            l.type = LightType::Envmap;
            envmap(src, e, &l);
        } else if (e.type == "area") {
            fail(src, e.line, "an area emitter must be nested inside the shape that emits");
        } else {
            fail(src, e.line, "unsupported emitter type " + quote(e.type) +
                                  " (point, spot, directional, constant, envmap, or area on shapes)");
        }
        const bool env = l.type == LightType::Constant || l.type == LightType::Envmap;
        if (env)
            for (const Light& other : scene_.lights)
                if (other.type == LightType::Constant || other.type == LightType::Envmap)
                    fail(src, e.line, "a second environment emitter (constant or envmap): iris takes one per scene");
        l.sampling_weight = sampling_weight(e);
        check_radiance(e, l.radiance);
        finish(e);
        scene_.lights.push_back(l);
        if (env) scene_.environment_light = int(scene_.lights.size() - 1);
    }

    // A light's unit direction from a parameter (or toWorld's image of +z); zero or non-finite fails.
    Vec3 light_direction(Plugin& e, Vec3 d, const char* from) {
        const float len = length(d);
        if (!(len > 0) || !std::isfinite(len)) {
            Prop* p = find(e, from);
            fail(*e.src, p ? p->line : e.line, e.what() + ": " + from + " gives no direction (zero or not finite)");
        }
        return d / len;
    }

    // emitter "envmap": a latitude-longitude image (EXR or Radiance HDR; PNG/JPEG decoded from sRGB),
    // times `scale`, oriented by toWorld (Mitsuba 0.5: +y up in the map's frame).
    void envmap(const Source& src, Plugin& e, Light* l) {
        std::optional<std::string> file = get_string(e, "filename");
        if (!file) fail(src, e.line, "emitter \"envmap\" needs a filename");
        const int fline = find(e, "filename")->line;
        const float scale = get_float(e, "scale", 1.0f);
        if (!(scale >= 0) || !std::isfinite(scale)) fail(src, find(e, "scale")->line, "envmap scale must be finite and >= 0");
        const Transform to_world = get_transform(e, "toWorld").value_or(Transform());
        if (!(std::abs(to_world.determinant3x3()) > 0)) fail(src, find(e, "toWorld")->line, "envmap toWorld is singular");
        if (find(e, "gamma")) get_float(e, "gamma");  // for LDR maps in Mitsuba; EXR/HDR are linear
        get_bool(e, "cache", false);                    // Mitsuba's MIP-map cache switch: no meaning here
        const fs::path path = resolve(src, *file);
        std::string bytes;
        if (!read_file(path, &bytes))
            fail(src, fline, "cannot read envmap file " + quote(*file) + " (resolved to " + path.string() + ")");
        fingerprint_.add(bytes);
        Image img;
        bool display_encoded = false;
        try {
            ImageFile f = read_image_file(path.string());
            img = std::move(f.image);
            display_encoded = f.display_encoded;
        } catch (const std::exception& ex) {
            fail(src, fline, "envmap " + quote(*file) + ": " + ex.what());
        }
        // PNG/JPEG maps hold sRGB-encoded values (Mitsuba decodes them so); EXR/HDR are linear radiance.
        if (display_encoded)
            for (int c : {img.channel_index("R"), img.channel_index("G"), img.channel_index("B")})
                if (c >= 0)
                    for (float& v : img.data[size_t(c)])
                        v = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
        const int ri = img.channel_index("R"), gi = img.channel_index("G"), bi = img.channel_index("B");
        const int yi = img.channel_index("Y");
        if ((ri < 0 || gi < 0 || bi < 0) && yi < 0)
            fail(src, fline, "envmap " + quote(*file) + " has neither R, G, B nor Y channels");
        std::vector<RGB> texels(size_t(std::max(0, img.width)) * size_t(std::max(0, img.height)));
        for (size_t i = 0; i < texels.size(); ++i)
            texels[i] = ri >= 0 && gi >= 0 && bi >= 0 ? RGB(img.data[ri][i], img.data[gi][i], img.data[bi][i]) * scale
                                                     : RGB(img.data[yi][i]) * scale;
        try {
            l->envmap = make_envmap(img.width, img.height, std::move(texels), to_world);
        } catch (const std::invalid_argument& ex) {
            fail(src, fline, "envmap " + quote(*file) + ": " + ex.what());
        }
    }

    void medium(const Source& src, pugi::xml_node n) {
        check_attrs(src, n, {"type", "id", "name"});
        const int line = src.line_of(n);
        std::string id = opt_attr(src, n, "id").value_or("");
        register_id(src, line, id, "medium");
        warn(src, line, "medium" + (id.empty() ? std::string() : " " + quote(id)) +
                            " ignored: iris renders no participating media, and no shape refers to it");
    }

    struct IdInfo {
        std::string tag, file;
        int line;
    };

    const SceneLoadOptions& options_;
    std::map<std::string, std::string> params_;
    std::vector<std::unique_ptr<Source>> sources_;
    std::map<std::string, NamedBsdf> named_bsdfs_;
    std::map<std::string, NamedTexture> named_textures_;
    std::map<std::string, int16_t> texture_by_key_;   // texture description -> index: equal ones are shared
    std::map<std::string, int16_t> decoded_by_file_;  // file|gamma|channel -> a texture holding its texels
    std::set<std::string> hashed_files_;              // texture files already in the fingerprint
    std::map<std::string, IdInfo> ids_;
    Fingerprint fingerprint_;
    Scene scene_;
    bool have_sensor_ = false, have_integrator_ = false;
    int default_bsdf_ = -1;
    int include_depth_ = 0;
    std::map<std::string, ShapeGroup> groups_;
    bool in_group_ = false;
};

}  // namespace

Scene parse_scene(const std::string& path, const SceneLoadOptions& options) { return Loader(options).run(path); }

Scene load_scene(const std::string& path, const SceneLoadOptions& options) {
    Scene scene = parse_scene(path, options);
    // finalize() reports problems the parser cannot see element by element with libcommon's own
    // exceptions: a light whose area or power overflows float (a rectangle scaled by 1e20, a radiance
    // of 3e38) made Distribution1D throw std::invalid_argument and lights_prepare std::runtime_error,
    // which escaped as messages without the file name (tests/data/fuzz-regressions/scene_xml/).
    // The contract is SceneError naming the file.
    try {
        scene.finalize();
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        throw SceneError(path + ": " + e.what());
    }
    return scene;
}

}  // namespace iris
