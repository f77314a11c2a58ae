// The XML layer of the scene reader: files, <default>/$parameters, plugin elements, ids and the
// unqueried-parameter bookkeeping (see xml.h). The typed parameter values are in values.cpp.
#include "formats/mitsuba/xml.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iostream>
#include <sstream>

namespace iris::mitsuba {

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

namespace {

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
        case Kind::Blackbody: return "<blackbody>";
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
    if (tag == "blackbody") return Kind::Blackbody;
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

}  // namespace

// ---- files ----------------------------------------------------------------------------------
const Source& XmlReader::open_source(const std::string& path, const Source* from, int from_line, const fs::path& resolved) {
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
    fingerprint.add(src->text);
    // parse_default: elements, attributes, text, CDATA, escapes; no comments, PIs or declarations.
    pugi::xml_parse_result r =
        src->doc.load_buffer(src->text.data(), src->text.size(), pugi::parse_default, pugi::encoding_auto);
    if (!r) fail(*src, src->line_at(r.offset), std::string("malformed XML: ") + r.description());
    sources_.push_back(std::move(src));
    return *sources_.back();
}

fs::path XmlReader::resolve(const Source& src, const std::string& file) const {
    fs::path p(file);
    return p.is_absolute() ? p : src.dir / p;
}

// ---- messages -------------------------------------------------------------------------------
void XmlReader::warn(const Source& src, int line, const std::string& msg) {
    std::string s = src.path + ":" + std::to_string(line) + ": " + msg;
    if (options_.warnings)
        options_.warnings->push_back(s);
    else if (!options_.quiet_warnings)
        std::cerr << "warning: " << s << "\n";
}

void XmlReader::check_attrs(const Source& src, pugi::xml_node n, std::initializer_list<const char*> allowed) {
    for (pugi::xml_attribute a : n.attributes()) {
        bool ok = false;
        for (const char* name : allowed) ok = ok || std::string_view(a.name()) == name;
        if (!ok)
            fail(src, src.line_of(n), "unknown attribute " + quote(a.name()) + " on <" + std::string(n.name()) + ">");
    }
}

// Element children only; stray text is an error (Mitsuba's schema has no text content).
void XmlReader::check_no_text(const Source& src, pugi::xml_node n) {
    for (pugi::xml_node c : n.children())
        if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata)
            fail(src, src.line_of(n), "unexpected text inside <" + std::string(n.name()) + ">");
}

// ---- $parameters ----------------------------------------------------------------------------
void XmlReader::collect_defaults(const Source& src, pugi::xml_node root) {
    for (pugi::xml_node c : root.children("default")) collect_default(src, c);
}

void XmlReader::collect_default(const Source& src, pugi::xml_node c) {
    check_attrs(src, c, {"name", "value"});
    check_no_text(src, c);
    if (!c.attribute("name") || !c.attribute("value"))
        fail(src, src.line_of(c), "<default> needs name and value attributes");
    params_.emplace(c.attribute("name").value(), c.attribute("value").value());  // first one wins
}

// Replaces every $identifier by its parameter value; an unknown one is an error.
std::string XmlReader::substitute(const Source& src, int line, std::string_view raw) const {
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

std::optional<std::string> XmlReader::opt_attr(const Source& src, pugi::xml_node n, const char* name) const {
    pugi::xml_attribute a = n.attribute(name);
    if (!a) return std::nullopt;
    return substitute(src, src.line_of(n), a.value());
}

std::string XmlReader::attr(const Source& src, pugi::xml_node n, const char* name) const {
    auto v = opt_attr(src, n, name);
    if (!v) fail(src, src.line_of(n), "<" + std::string(n.name()) + "> needs a " + quote(name) + " attribute");
    return *v;
}

// ---- reading a plugin element ---------------------------------------------------------------
Plugin XmlReader::read_plugin(const Source& src, pugi::xml_node n) {
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
        } else if (tag == "default") {
            // Mitsuba's schema allows <default> in any plugin element, and its value serves every later
            // $name as one at the top does (the first one of a name wins; the caller's values win over
            // all). The improved-path-guiding fork's scenes put one inside BSDFs.
            collect_default(src, c);
        } else if (tag == "animation") {
            fail(src, src.line_of(c), "<" + tag + "> is not supported");
        } else {
            fail(src, src.line_of(c), "unknown element <" + tag + "> in " + p.what());
        }
    }
    register_id(src, p.line, p.id, p.tag);
    return p;
}

void XmlReader::register_id(const Source& src, int line, const std::string& id, const std::string& tag) {
    if (id.empty()) return;
    auto [it, inserted] = ids_.emplace(id, IdInfo{tag, src.path, line});
    if (!inserted)
        fail(src, line, "duplicate id " + quote(id) + " (first used at " + it->second.file + ":" +
                            std::to_string(it->second.line) + ")");
}

const IdInfo* XmlReader::id_info(const std::string& id) const {
    auto it = ids_.find(id);
    return it == ids_.end() ? nullptr : &it->second;
}

Prop* XmlReader::find(Plugin& p, const std::string& name) {
    for (Prop& prop : p.props)
        if (prop.name == name) return &prop;
    return nullptr;
}

void XmlReader::wrong_kind(const Plugin& p, const Prop& prop, const char* expected) {
    fail(*p.src, prop.line, "parameter " + quote(prop.name) + " of " + p.what() + " must be " + expected + ", not " +
                                kind_name(prop.kind));
}

std::string XmlReader::what(const Plugin& p, const Prop& prop) const { return "parameter " + quote(prop.name) + " of " + p.what(); }

// The "value" attribute of a simple parameter, substituted.
std::string XmlReader::value_of(const Plugin& p, const Prop& prop) {
    check_attrs(*p.src, prop.node, {"name", "value"});
    check_no_text(*p.src, prop.node);
    return attr(*p.src, prop.node, "value");
}

// Every parameter must have been queried, or be one the plugin accepts without using it.
void XmlReader::finish(Plugin& p, const IgnoreRule& ignore) {
    for (Prop& prop : p.props) {
        if (prop.used) continue;
        const char* why = ignore ? ignore(prop.name) : nullptr;
        if (why)
            warn(*p.src, prop.line, "parameter " + quote(prop.name) + " of " + p.what() + " ignored: " + why);
        else if (options_.strict)
            fail(*p.src, prop.line, "unknown parameter " + quote(prop.name) + " for " + p.what() + " (--strict)");
        else  // as Mitsuba's "Unqueried attribute" warning: the scene still renders
            warn(*p.src, prop.line, "parameter " + quote(prop.name) + " of " + p.what() +
                                        " is not read by this plugin; ignored (--strict makes it an error)");
    }
}

void XmlReader::no_children(const Plugin& p) {
    if (p.children.empty()) return;
    pugi::xml_node c = p.children[0];
    // A nested <texture> is a textured parameter (Mitsuba's bitmap, checkerboard, ...): name the
    // plugin, so the user knows what iris lacks rather than reading a syntax complaint.
    if (std::string(c.name()) == "texture")
        fail(*p.src, p.src->line_of(c),
             "unsupported plugin " + quote(c.attribute("type").value()) + " (texture for parameter " +
                 quote(c.attribute("name").value()) + " of " + p.what() + "; iris textures BSDF parameters only)");
    fail(*p.src, p.src->line_of(c), std::string("<") + c.name() + "> is not allowed inside " + p.what());
}


}  // namespace iris::mitsuba
