#include "formats/ply.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

namespace iris {
namespace {

enum class Type : uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };

int type_size(Type t) {
    switch (t) {
        case Type::I8: case Type::U8: return 1;
        case Type::I16: case Type::U16: return 2;
        case Type::I32: case Type::U32: case Type::F32: return 4;
        case Type::F64: return 8;
    }
    return 0;
}

bool type_of(std::string_view s, Type* t) {
    struct Name {
        const char* name;
        Type type;
    };
    static const Name names[] = {{"char", Type::I8},     {"int8", Type::I8},     {"uchar", Type::U8},
                                 {"uint8", Type::U8},    {"short", Type::I16},   {"int16", Type::I16},
                                 {"ushort", Type::U16},  {"uint16", Type::U16},  {"int", Type::I32},
                                 {"int32", Type::I32},   {"uint", Type::U32},    {"uint32", Type::U32},
                                 {"float", Type::F32},   {"float32", Type::F32}, {"double", Type::F64},
                                 {"float64", Type::F64}};
    for (const Name& n : names)
        if (s == n.name) {
            *t = n.type;
            return true;
        }
    return false;
}

bool is_float(Type t) { return t == Type::F32 || t == Type::F64; }

// What a vertex property feeds: a slot of the output, or nothing.
enum Slot : int8_t { None = -1, X, Y, Z, NX, NY, NZ, U, V };

struct Property {
    std::string name;
    Type type = Type::F32;
    bool list = false;
    Type count_type = Type::U8;  // lists only
    int8_t slot = None;          // vertex properties
    bool indices = false;        // the face element's vertex index list
};

struct Element {
    std::string name;
    uint64_t count = 0;
    std::vector<Property> props;
};

enum class Format : uint8_t { Ascii, Little, Big };

bool space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

class PlyParser {
public:
    PlyParser(std::string_view bytes, const std::string& name) : b_(bytes), name_(name) {}

    TriangleMesh run() {
        header();
        ++line_;  // ASCII data start on the line after end_header
        const Element* vertex = nullptr;
        for (const Element& e : elements_) {
            if (e.name == "vertex") vertex = &e;
        }
        if (!vertex) fail_header("no \"vertex\" element");
        if (!face_) fail_header("no \"face\" element with a vertex_indices list");
        if (vertex->count > std::numeric_limits<uint32_t>::max())
            fail_header("more than 2^32 - 1 vertices");
        bool have[8] = {};
        for (const Property& p : vertex->props)
            if (p.slot != None) have[p.slot] = true;
        if (!have[X] || !have[Y] || !have[Z]) fail_header("the vertex element lacks x, y or z");
        has_normals_ = have[NX] && have[NY] && have[NZ];
        has_uvs_ = have[U] && have[V];
        for (const Element& e : elements_) read_element(e);
        if (pos_ != b_.size()) {
            // Trailing whitespace after ASCII data is harmless; anything else means the counts are wrong.
            size_t p = pos_;
            if (format_ == Format::Ascii)
                while (p < b_.size() && space(b_[p])) ++p;
            if (p != b_.size())
                fail_here("data continue after the last element (" + std::to_string(b_.size() - pos_) +
                          " bytes): the element counts do not match the data");
        }
        for (uint32_t i : mesh_.indices)
            if (i >= mesh_.positions.size())
                throw MeshFileError(name_ + ": a face refers to vertex " + std::to_string(i) + " but the file has " +
                                    std::to_string(mesh_.positions.size()) + " (indices start at 0)");
        if (mesh_.indices.empty()) throw MeshFileError(name_ + ": the mesh has no faces");
        return std::move(mesh_);
    }

private:
    [[noreturn]] void fail_header(const std::string& msg) const {
        throw MeshFileError(name_ + ":" + std::to_string(line_) + ": PLY header: " + msg);
    }
    [[noreturn]] void fail_here(const std::string& msg) const {
        if (format_ == Format::Ascii) throw MeshFileError(name_ + ":" + std::to_string(line_) + ": " + msg);
        throw MeshFileError(name_ + ": at byte " + std::to_string(pos_) + ": " + msg);
    }

    // ---- header ---------------------------------------------------------------------------------
    std::string_view header_line() {
        if (pos_ >= b_.size()) fail_header("the file ends before end_header");
        size_t end = b_.find('\n', pos_);
        if (end == std::string_view::npos) fail_header("the file ends before end_header");
        std::string_view l = b_.substr(pos_, end - pos_);
        if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
        pos_ = end + 1;
        ++line_;
        return l;
    }

    static std::vector<std::string_view> words(std::string_view l) {
        std::vector<std::string_view> w;
        size_t i = 0;
        while (i < l.size()) {
            while (i < l.size() && space(l[i])) ++i;
            size_t j = i;
            while (j < l.size() && !space(l[j])) ++j;
            if (j > i) w.push_back(l.substr(i, j - i));
            i = j;
        }
        return w;
    }

    void header() {
        if (header_line() != "ply") {
            line_ = 1;
            fail_header("not a PLY file (the first line is not \"ply\")");
        }
        bool have_format = false;
        for (;;) {
            std::vector<std::string_view> w = words(header_line());
            if (w.empty()) continue;
            if (w[0] == "end_header") break;
            if (w[0] == "comment" || w[0] == "obj_info") continue;
            if (w[0] == "format") {
                if (w.size() != 3) fail_header("bad format line");
                if (w[1] == "ascii") format_ = Format::Ascii;
                else if (w[1] == "binary_little_endian") format_ = Format::Little;
                else if (w[1] == "binary_big_endian") format_ = Format::Big;
                else fail_header("unknown format \"" + std::string(w[1]) + "\"");
                if (w[2] != "1.0") fail_header("unsupported PLY version \"" + std::string(w[2]) + "\"");
                have_format = true;
            } else if (w[0] == "element") {
                if (w.size() != 3) fail_header("bad element line");
                Element e;
                e.name = std::string(w[1]);
                auto [p, ec] = std::from_chars(w[2].data(), w[2].data() + w[2].size(), e.count);
                if (ec != std::errc() || p != w[2].data() + w[2].size())
                    fail_header("bad element count \"" + std::string(w[2]) + "\"");
                for (const Element& o : elements_)
                    if (o.name == e.name) fail_header("element \"" + e.name + "\" declared twice");
                elements_.push_back(std::move(e));
            } else if (w[0] == "property") {
                if (elements_.empty()) fail_header("a property before any element");
                Element& e = elements_.back();
                Property p;
                if (w.size() == 5 && w[1] == "list") {
                    p.list = true;
                    if (!type_of(w[2], &p.count_type) || !type_of(w[3], &p.type))
                        fail_header("unknown type in list property \"" + std::string(w[4]) + "\"");
                    if (is_float(p.count_type)) fail_header("a list count of floating-point type");
                    p.name = std::string(w[4]);
                } else if (w.size() == 3) {
                    if (!type_of(w[1], &p.type)) fail_header("unknown property type \"" + std::string(w[1]) + "\"");
                    p.name = std::string(w[2]);
                } else {
                    fail_header("bad property line");
                }
                for (const Property& o : e.props)
                    if (o.name == p.name) fail_header("property \"" + p.name + "\" declared twice");
                if (e.name == "vertex" && !p.list) p.slot = vertex_slot(p.name);
                if (e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index")) {
                    if (!p.list) fail_header("vertex_indices must be a list");
                    if (is_float(p.type)) fail_header("vertex indices of floating-point type");
                    for (const Property& o : e.props)
                        if (o.indices) fail_header("both vertex_indices and vertex_index");
                    p.indices = true;
                    face_ = true;
                }
                e.props.push_back(std::move(p));
            } else {
                fail_header("unknown header keyword \"" + std::string(w[0]) + "\"");
            }
        }
        if (!have_format) fail_header("no format line");
    }

    static int8_t vertex_slot(const std::string& n) {
        if (n == "x") return X;
        if (n == "y") return Y;
        if (n == "z") return Z;
        if (n == "nx") return NX;
        if (n == "ny") return NY;
        if (n == "nz") return NZ;
        if (n == "u" || n == "s" || n == "texture_u" || n == "texture_s") return U;
        if (n == "v" || n == "t" || n == "texture_v" || n == "texture_t") return V;
        return None;
    }

    // ---- values ---------------------------------------------------------------------------------
    // Next ASCII token; counts lines. Empty at the end of the data.
    std::string_view token() {
        while (pos_ < b_.size() && space(b_[pos_])) {
            if (b_[pos_] == '\n') ++line_;
            ++pos_;
        }
        size_t s = pos_;
        while (pos_ < b_.size() && !space(b_[pos_])) ++pos_;
        return b_.substr(s, pos_ - s);
    }

    template <class T>
    T load(const char* p) const {
        T v;
        std::memcpy(&v, p, sizeof v);
        if (format_ == Format::Big) {
            unsigned char* c = reinterpret_cast<unsigned char*>(&v);
            for (size_t i = 0; i < sizeof v / 2; ++i) std::swap(c[i], c[sizeof v - 1 - i]);
        }
        return v;
    }

    [[noreturn]] void truncated(const Element& e, uint64_t i) const {
        const std::string msg = "the file ends in element \"" + e.name + "\" (" + std::to_string(i) + " of " +
                                std::to_string(e.count) + " read): truncated?";
        if (format_ == Format::Ascii) throw MeshFileError(name_ + ":" + std::to_string(line_) + ": " + msg);
        throw MeshFileError(name_ + ": " + msg);
    }

    // A value as double (floats, and integers exactly up to 2^53, which covers every PLY integer type).
    double value(Type t, const Element& e, uint64_t i, bool want_int) {
        if (format_ == Format::Ascii) {
            std::string_view tok = token();
            if (tok.empty()) truncated(e, i);
            double v = 0;
            const char* f = tok.data();
            const char* l = tok.data() + tok.size();
            if (f != l && *f == '+') ++f;
            if (is_float(t) && !want_int) {
                auto [p, ec] = std::from_chars(f, l, v);
                if (ec != std::errc() || p != l) fail_here("bad number \"" + std::string(tok) + "\" in element \"" + e.name + "\"");
                if (t == Type::F32) v = double(float(v));
            } else {
                int64_t n = 0;
                auto [p, ec] = std::from_chars(f, l, n);
                if (ec != std::errc() || p != l)
                    fail_here("bad integer \"" + std::string(tok) + "\" in element \"" + e.name + "\"");
                v = double(n);
            }
            return v;
        }
        const int n = type_size(t);
        if (b_.size() - pos_ < size_t(n)) truncated(e, i);
        const char* p = b_.data() + pos_;
        pos_ += size_t(n);
        switch (t) {
            case Type::I8: return double(int8_t(*p));
            case Type::U8: return double(uint8_t(*p));
            case Type::I16: return double(load<int16_t>(p));
            case Type::U16: return double(load<uint16_t>(p));
            case Type::I32: return double(load<int32_t>(p));
            case Type::U32: return double(load<uint32_t>(p));
            case Type::F32: return double(load<float>(p));
            case Type::F64: return load<double>(p);
        }
        return 0;
    }

    // ---- elements -------------------------------------------------------------------------------
    void read_element(const Element& e) {
        const bool is_vertex = e.name == "vertex";
        const bool is_face = e.name == "face";
        // Reserve from the declared count only as far as the remaining bytes could hold, so that a
        // header claiming 10^18 vertices fails as truncated instead of allocating.
        const uint64_t fit = uint64_t(b_.size() - pos_) / 2 + 1;
        const size_t expect = size_t(std::min<uint64_t>(e.count, fit));
        if (is_vertex) {
            mesh_.positions.resize(expect);
            if (has_normals_) mesh_.normals.resize(expect);
            if (has_uvs_) mesh_.uvs.resize(expect);
        }
        if (is_face) mesh_.indices.reserve(3 * expect);
        for (uint64_t i = 0; i < e.count; ++i) {
            if (is_vertex && i >= mesh_.positions.size()) {
                const size_t grow = std::min<size_t>(size_t(e.count), 2 * mesh_.positions.size() + 16);
                mesh_.positions.resize(grow);
                if (has_normals_) mesh_.normals.resize(grow);
                if (has_uvs_) mesh_.uvs.resize(grow);
            }
            float slot[8] = {};
            for (const Property& p : e.props) {
                if (p.list) {
                    const double nd = value(p.count_type, e, i, true);
                    if (nd < 0) fail_here("negative list length in element \"" + e.name + "\"");
                    const uint64_t n = uint64_t(nd);
                    if (p.indices) {
                        if (n < 3) fail_here("face " + std::to_string(i) + " has " + std::to_string(n) + " corners (at least 3 needed)");
                        face(p, e, i, n);
                    } else {
                        for (uint64_t k = 0; k < n; ++k) value(p.type, e, i, !is_float(p.type));
                    }
                    continue;
                }
                const double v = value(p.type, e, i, !is_float(p.type));
                if (is_vertex && p.slot != None) {
                    const float f = float(v);
                    if (!std::isfinite(f))
                        fail_here("vertex " + std::to_string(i) + " has a non-finite " + p.name);
                    slot[p.slot] = f;
                }
            }
            if (is_vertex) {
                mesh_.positions[i] = Vec3(slot[X], slot[Y], slot[Z]);
                if (has_normals_) mesh_.normals[i] = Vec3(slot[NX], slot[NY], slot[NZ]);
                if (has_uvs_) mesh_.uvs[i] = Vec2{slot[U], slot[V]};
            }
        }
    }

    // Reads one face's n indices and appends the fan (0, k, k+1); no per-face allocation.
    void face(const Property& p, const Element& e, uint64_t i, uint64_t n) {
        uint32_t first = 0, prev = 0;
        for (uint64_t k = 0; k < n; ++k) {
            const double d = value(p.type, e, i, true);
            if (d < 0 || d > double(std::numeric_limits<uint32_t>::max()))
                fail_here("face " + std::to_string(i) + " has a vertex index " + std::to_string(int64_t(d)) + " out of range");
            const uint32_t idx = uint32_t(d);
            if (k == 0) first = idx;
            else if (k >= 2) mesh_.indices.insert(mesh_.indices.end(), {first, prev, idx});
            prev = idx;
        }
    }

    std::string_view b_;
    const std::string& name_;
    size_t pos_ = 0;
    uint64_t line_ = 0;
    Format format_ = Format::Ascii;
    std::vector<Element> elements_;
    bool face_ = false, has_normals_ = false, has_uvs_ = false;
    TriangleMesh mesh_;
};

}  // namespace

TriangleMesh parse_ply(std::string_view bytes, const std::string& name) { return PlyParser(bytes, name).run(); }

}  // namespace iris
