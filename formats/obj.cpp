#include "formats/obj.h"

#include <charconv>
#include <cmath>
#include <limits>

namespace iris {
namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

class Parser {
public:
    Parser(std::string_view text, const std::string& name) : text_(text), name_(name) {}

    ObjMesh run() {
        size_t pos = 0;
        while (pos < text_.size()) {
            size_t end = text_.find('\n', pos);
            if (end == std::string_view::npos) end = text_.size();
            ++line_;
            statement(text_.substr(pos, end - pos));
            pos = end + 1;
        }
        // Positive indices may name vertices defined further down; check them once all are known.
        for (size_t f = 0, c = 0; f < mesh_.face_sizes.size(); ++f)
            for (uint32_t i = 0; i < mesh_.face_sizes[f]; ++i, ++c) {
                const ObjMesh::Corner& k = mesh_.corners[c];
                if (k.v >= mesh_.positions.size())
                    fail(mesh_.face_lines[f], "face refers to vertex " + std::to_string(k.v + 1) + " but the file has " +
                                                  std::to_string(mesh_.positions.size()));
                if (k.n >= 0 && size_t(k.n) >= mesh_.normals.size())
                    fail(mesh_.face_lines[f], "face refers to normal " + std::to_string(k.n + 1) + " but the file has " +
                                                  std::to_string(mesh_.normals.size()));
                if (k.t >= 0 && size_t(k.t) >= mesh_.texcoords.size())
                    fail(mesh_.face_lines[f], "face refers to texture coordinate " + std::to_string(k.t + 1) +
                                                  " but the file has " + std::to_string(mesh_.texcoords.size()));
            }
        return std::move(mesh_);
    }

private:
    [[noreturn]] void fail(uint32_t line, const std::string& msg) const {
        throw ObjError(name_ + ":" + std::to_string(line) + ": " + msg);
    }
    [[noreturn]] void fail(const std::string& msg) const { fail(line_, msg); }

    // Splits off the next whitespace-separated token of `s` (empty at the end).
    static std::string_view next_token(std::string_view& s) {
        size_t b = 0;
        while (b < s.size() && is_space(s[b])) ++b;
        size_t e = b;
        while (e < s.size() && !is_space(s[e])) ++e;
        std::string_view tok = s.substr(b, e - b);
        s = s.substr(e);
        return tok;
    }

    float number(std::string_view tok, const char* what) const {
        float v = 0;
        const char* first = tok.data();
        const char* last = tok.data() + tok.size();
        if (first != last && *first == '+') ++first;  // from_chars does not take a leading '+'
        auto [ptr, ec] = std::from_chars(first, last, v);
        if (ec != std::errc() || ptr != last || tok.empty())
            fail("bad number \"" + std::string(tok) + "\" in " + what);
        if (!std::isfinite(v)) fail(std::string(what) + " has a non-finite coordinate \"" + std::string(tok) + "\"");
        return v;
    }

    Vec3 vec3(std::string_view rest, const char* what, bool allow_extra) const {
        Vec3 r;
        for (int i = 0; i < 3; ++i) {
            std::string_view tok = next_token(rest);
            if (tok.empty()) fail(std::string(what) + " needs three coordinates");
            r[i] = number(tok, what);
        }
        // "v x y z w" or "v x y z r g b" (vertex colours): the extra values are not used but must be numbers.
        int extra = 0;
        for (std::string_view tok = next_token(rest); !tok.empty(); tok = next_token(rest), ++extra) {
            if (!allow_extra || extra >= 4) fail(std::string("too many values in ") + what);
            number(tok, what);
        }
        return r;
    }

    // OBJ index (1-based, or negative = relative to the current end) -> 0-based.
    int64_t index(std::string_view tok, size_t count, const char* what) const {
        int64_t i = 0;
        auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), i);
        if (ec != std::errc() || ptr != tok.data() + tok.size() || tok.empty())
            fail("bad " + std::string(what) + " index \"" + std::string(tok) + "\"");
        if (i == 0) fail(std::string(what) + " index 0 (OBJ indices start at 1)");
        if (i < 0) {
            // Compared as i < -count, not -i > count: negating INT64_MIN ("f -9223372036854775808 ...")
            // overflows, undefined behaviour that UBSan reported.
            if (i < -int64_t(count))
                fail("relative " + std::string(what) + " index " + std::to_string(i) + " reaches before the first one");
            return int64_t(count) + i;
        }
        if (i > int64_t(std::numeric_limits<int32_t>::max())) fail(std::string(what) + " index too large");
        return i - 1;
    }

    void face(std::string_view rest) {
        uint32_t n = 0;
        for (std::string_view tok = next_token(rest); !tok.empty(); tok = next_token(rest), ++n) {
            // v | v/vt | v//vn | v/vt/vn
            size_t s1 = tok.find('/');
            std::string_view vs = tok.substr(0, s1), ts, ns;
            if (s1 != std::string_view::npos) {
                size_t s2 = tok.find('/', s1 + 1);
                ts = tok.substr(s1 + 1, s2 == std::string_view::npos ? std::string_view::npos : s2 - s1 - 1);
                if (s2 != std::string_view::npos) {
                    ns = tok.substr(s2 + 1);
                    if (ns.find('/') != std::string_view::npos) fail("bad face corner \"" + std::string(tok) + "\"");
                    if (ns.empty()) fail("bad face corner \"" + std::string(tok) + "\"");
                }
            }
            ObjMesh::Corner c;
            c.v = uint32_t(index(vs, mesh_.positions.size(), "vertex"));
            c.t = ts.empty() ? -1 : int32_t(index(ts, mesh_.texcoords.size(), "texture coordinate"));
            c.n = ns.empty() ? -1 : int32_t(index(ns, mesh_.normals.size(), "normal"));
            mesh_.corners.push_back(c);
        }
        if (n < 3) fail("face with " + std::to_string(n) + " corners (at least 3 needed)");
        mesh_.face_sizes.push_back(n);
        mesh_.face_lines.push_back(line_);
    }

    void statement(std::string_view s) {
        size_t hash = s.find('#');
        if (hash != std::string_view::npos) s = s.substr(0, hash);
        std::string_view key = next_token(s);
        if (key.empty()) return;
        if (key == "v") {
            mesh_.positions.push_back(vec3(s, "vertex", true));
        } else if (key == "vn") {
            mesh_.normals.push_back(vec3(s, "normal", false));
        } else if (key == "f") {
            face(s);
        } else if (key == "vt") {
            // "vt u [v [w]]": v defaults to 0 (the OBJ specification), w (3D textures) is not used.
            Vec2 t;
            std::string_view tok = next_token(s);
            if (tok.empty()) fail("texture coordinate needs at least u");
            t.x = number(tok, "texture coordinate");
            if (tok = next_token(s); !tok.empty()) t.y = number(tok, "texture coordinate");
            if (tok = next_token(s); !tok.empty()) number(tok, "texture coordinate");
            if (!next_token(s).empty()) fail("too many values in texture coordinate");
            mesh_.texcoords.push_back(t);
        } else if (key == "vp" || key == "o" || key == "g" || key == "s" || key == "usemtl" ||
                   key == "mtllib" || key == "l" || key == "p" || key == "mg" || key == "maplib" ||
                   key == "usemap" || key == "lod" || key == "shadow_obj" || key == "trace_obj" ||
                   key == "bevel" || key == "c_interp" || key == "d_interp") {
            // Parameter-space vertices, grouping, materials, lines and points: nothing iris renders.
        } else {
            fail("unsupported OBJ statement \"" + std::string(key) + "\"");
        }
    }

    std::string_view text_;
    const std::string& name_;
    uint32_t line_ = 0;
    ObjMesh mesh_;
};

}  // namespace

ObjMesh parse_obj(std::string_view text, const std::string& name) { return Parser(text, name).run(); }

}  // namespace iris
