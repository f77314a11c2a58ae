// The typed values of a plugin element's parameters: numbers, booleans, strings, points, colours
// (in spectra.cpp), refractive indices and <transform>s (see xml.h).
#include <cctype>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <type_traits>

#include "formats/mitsuba/xml.h"
#include "libcommon/spectrum.h"

namespace iris::mitsuba {

// ---- numbers --------------------------------------------------------------------------------
namespace {
// A whole number of type T in s, surrounding white space and a leading '+' allowed (as Mitsuba's
// strtod/strtol read them); false for anything else, a non-finite float included.
template <typename T>
bool read_number(std::string_view s, T* v) {
    const char* first = s.data();
    const char* last = s.data() + s.size();
    while (first < last && std::isspace(static_cast<unsigned char>(*first))) ++first;
    while (last > first && std::isspace(static_cast<unsigned char>(last[-1]))) --last;
    if (first < last && *first == '+') ++first;
    auto [ptr, ec] = std::from_chars(first, last, *v);
    if constexpr (std::is_floating_point_v<T>)
        if (!std::isfinite(*v)) return false;
    return first != last && ec == std::errc() && ptr == last;
}
}  // namespace

float XmlReader::parse_float(const Source& src, int line, std::string_view s, const std::string& what) const {
    float v = 0;
    if (!read_number(s, &v)) fail(src, line, "bad number " + quote(s) + " for " + what);
    return v;
}

int XmlReader::parse_int(const Source& src, int line, std::string_view s, const std::string& what) const {
    int v = 0;
    if (!read_number(s, &v)) fail(src, line, "bad integer " + quote(s) + " for " + what);
    return v;
}

std::vector<float> XmlReader::parse_floats(const Source& src, int line, std::string_view s, const std::string& what) const {
    std::vector<float> out;
    for (std::string_view t : tokens(s)) out.push_back(parse_float(src, line, t, what));
    return out;
}

Vec3 XmlReader::parse_vec3(const Source& src, int line, std::string_view s, const std::string& what) const {
    std::vector<float> v = parse_floats(src, line, s, what);
    if (v.size() != 3) fail(src, line, "expected three numbers for " + what + ", got " + quote(s));
    return Vec3(v[0], v[1], v[2]);
}

std::optional<float> XmlReader::get_float(Plugin& p, const std::string& name) {
    Prop* prop = find(p, name);
    if (!prop) return std::nullopt;
    prop->used = true;
    if (prop->kind == Kind::Integer) return float(parse_int(*p.src, prop->line, value_of(p, *prop), what(p, *prop)));
    if (prop->kind != Kind::Float) wrong_kind(p, *prop, "a <float>");
    return parse_float(*p.src, prop->line, value_of(p, *prop), what(p, *prop));
}
float XmlReader::get_float(Plugin& p, const std::string& name, float def) { return get_float(p, name).value_or(def); }

std::optional<int> XmlReader::get_int(Plugin& p, const std::string& name) {
    Prop* prop = find(p, name);
    if (!prop) return std::nullopt;
    prop->used = true;
    if (prop->kind != Kind::Integer) wrong_kind(p, *prop, "an <integer>");
    return parse_int(*p.src, prop->line, value_of(p, *prop), what(p, *prop));
}
int XmlReader::get_int(Plugin& p, const std::string& name, int def) { return get_int(p, name).value_or(def); }

bool XmlReader::get_bool(Plugin& p, const std::string& name, bool def) {
    Prop* prop = find(p, name);
    if (!prop) return def;
    prop->used = true;
    if (prop->kind != Kind::Boolean) wrong_kind(p, *prop, "a <boolean>");
    std::string v = lower(value_of(p, *prop));
    if (v == "true") return true;
    if (v == "false") return false;
    fail(*p.src, prop->line, "bad boolean " + quote(v) + " for " + what(p, *prop) + " (true or false)");
}

std::optional<std::string> XmlReader::get_string(Plugin& p, const std::string& name) {
    Prop* prop = find(p, name);
    if (!prop) return std::nullopt;
    prop->used = true;
    if (prop->kind != Kind::String) wrong_kind(p, *prop, "a <string>");
    return value_of(p, *prop);
}
std::string XmlReader::get_string(Plugin& p, const std::string& name, const std::string& def) {
    return get_string(p, name).value_or(def);
}

std::optional<Vec3> XmlReader::get_point(Plugin& p, const std::string& name) {
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

// get_spectrum: spectra.cpp.


// A refractive index given as a number or as one of Mitsuba's material names.
float XmlReader::get_ior(Plugin& p, const std::string& name, const char* def) {
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

std::optional<Transform> XmlReader::get_transform(Plugin& p, const std::string& name) {
    Prop* prop = find(p, name);
    if (!prop) return std::nullopt;
    prop->used = true;
    if (prop->kind != Kind::Transform) wrong_kind(p, *prop, "a <transform>");
    return parse_transform(*p.src, prop->node);
}

// <transform>: the operations apply in the order listed, M = T_n ... T_1.
Transform XmlReader::parse_transform(const Source& src, pugi::xml_node n) {
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

}  // namespace iris::mitsuba
