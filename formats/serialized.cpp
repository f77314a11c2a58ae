#include "formats/serialized.h"

#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

namespace iris {
namespace {

constexpr uint16_t kFormatTag = 0x041C;
constexpr uint32_t kVertexNormals = 0x0001, kTexcoords = 0x0002, kColors = 0x0008, kFaceNormals = 0x0010,
                   kSingle = 0x1000, kDouble = 0x2000;
// deflate cannot compress better than about 1032:1 (RFC 1951: a 258-byte match costs at least 2 bits),
// so a stream of n bytes inflates to at most this many times n: a bound on credible element counts.
constexpr uint64_t kMaxInflateRatio = 1032;

// Reads little-endian values from raw bytes.
template <class T>
T little(const char* p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    if constexpr (std::endian::native == std::endian::big) {
        unsigned char* c = reinterpret_cast<unsigned char*>(&v);
        for (size_t i = 0; i < sizeof v / 2; ++i) std::swap(c[i], c[sizeof v - 1 - i]);
    }
    return v;
}

template <class T>
void put_little(std::string* out, T v) {
    char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    if constexpr (std::endian::native == std::endian::big)
        for (size_t i = 0; i < sizeof v / 2; ++i) std::swap(b[i], b[sizeof v - 1 - i]);
    out->append(b, sizeof v);
}

struct Dictionary {
    uint16_t version = 4;
    std::vector<uint64_t> offsets;  // start of each shape
    uint64_t end = 0;               // where the dictionary starts (the end of the last shape)
};

[[noreturn]] void fail(const std::string& name, const std::string& msg) { throw MeshFileError(name + ": " + msg); }

Dictionary dictionary(std::string_view b, const std::string& name) {
    if (b.size() < 4 + 4) fail(name, "not a Mitsuba serialized mesh (only " + std::to_string(b.size()) + " bytes)");
    Dictionary d;
    if (little<uint16_t>(b.data()) != kFormatTag)
        fail(name, "not a Mitsuba serialized mesh (the file does not start with the format tag 0x041C)");
    d.version = little<uint16_t>(b.data() + 2);
    if (d.version != 3 && d.version != 4)
        fail(name, "unsupported serialized mesh version " + std::to_string(d.version) + " (3 and 4 are supported)");
    const uint64_t count = little<uint32_t>(b.data() + b.size() - 4);
    const uint64_t entry = d.version == 4 ? 8 : 4;
    if (count == 0 || count > (b.size() - 4) / (entry + 4))
        fail(name, "corrupt or truncated serialized mesh: its dictionary claims " + std::to_string(count) +
                       " shapes in " + std::to_string(b.size()) + " bytes");
    d.end = b.size() - 4 - count * entry;
    d.offsets.resize(count);
    for (uint64_t i = 0; i < count; ++i) {
        const char* p = b.data() + d.end + i * entry;
        d.offsets[i] = entry == 8 ? little<uint64_t>(p) : little<uint32_t>(p);
        const uint64_t prev_end = i == 0 ? 0 : d.offsets[i - 1] + 4;
        if (d.offsets[i] < prev_end || d.offsets[i] + 4 > d.end || (i == 0 && d.offsets[i] != 0))
            fail(name, "corrupt or truncated serialized mesh: shape " + std::to_string(i) + "'s offset " +
                           std::to_string(d.offsets[i]) + " does not fit the file (" + std::to_string(b.size()) + " bytes)");
    }
    return d;
}

// Inflates a zlib stream piece by piece straight into the caller's arrays.
class Inflater {
public:
    Inflater(std::string_view in, const std::string& what) : what_(what) {
        std::memset(&z_, 0, sizeof z_);
        if (inflateInit(&z_) != Z_OK) throw MeshFileError(what_ + ": zlib cannot start");
        z_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
        z_.avail_in = uInt(std::min<size_t>(in.size(), std::numeric_limits<uInt>::max()));
        rest_ = in.size() - z_.avail_in;
    }
    ~Inflater() { inflateEnd(&z_); }
    Inflater(const Inflater&) = delete;
    Inflater& operator=(const Inflater&) = delete;

    void read(void* dst, size_t n, const char* field) {
        char* out = static_cast<char*>(dst);
        while (n > 0) {
            if (ended_) throw MeshFileError(what_ + ": the compressed data end in the " + field + " (truncated or corrupt)");
            const uInt chunk = uInt(std::min<size_t>(n, 1u << 30));
            z_.next_out = reinterpret_cast<Bytef*>(out);
            z_.avail_out = chunk;
            if (z_.avail_in == 0 && rest_ > 0) {
                const uInt more = uInt(std::min<size_t>(rest_, std::numeric_limits<uInt>::max()));
                rest_ -= more;
                z_.avail_in = more;
            }
            const int r = inflate(&z_, Z_NO_FLUSH);
            const size_t got = chunk - z_.avail_out;
            out += got;
            n -= got;
            if (r == Z_STREAM_END) ended_ = true;
            else if (r == Z_BUF_ERROR && z_.avail_in == 0 && rest_ == 0)
                throw MeshFileError(what_ + ": the compressed data end in the " + field + " (truncated)");
            else if (r != Z_OK && r != Z_BUF_ERROR)
                throw MeshFileError(what_ + ": corrupt compressed data in the " + field + " (zlib: " +
                                    (z_.msg ? z_.msg : "error " + std::to_string(r)) + ")");
        }
    }

    template <class T>
    T value(const char* field) {
        char b[sizeof(T)];
        read(b, sizeof b, field);
        return little<T>(b);
    }

private:
    z_stream z_;
    size_t rest_ = 0;
    bool ended_ = false;
    std::string what_;
};

// n values of 3 (or 2) floats or doubles into floats; rejects non-finite ones.
void read_reals(Inflater& in, float* out, size_t count, bool dbl, const char* field, const std::string& what) {
    if (!dbl) {
        in.read(out, count * sizeof(float), field);
        if constexpr (std::endian::native == std::endian::big)
            for (size_t i = 0; i < count; ++i) out[i] = little<float>(reinterpret_cast<const char*>(out + i));
    } else {
        // Doubles in blocks through a fixed buffer: no allocation the size of the mesh.
        double buf[4096];
        for (size_t done = 0; done < count;) {
            const size_t n = std::min<size_t>(count - done, 4096);
            in.read(buf, n * sizeof(double), field);
            for (size_t i = 0; i < n; ++i) {
                const double v = little<double>(reinterpret_cast<const char*>(buf + i));
                out[done + i] = float(v);
            }
            done += n;
        }
    }
    for (size_t i = 0; i < count; ++i)
        if (!std::isfinite(out[i]))
            throw MeshFileError(what + ": a non-finite value in the " + field + " (value " + std::to_string(i / 3) + ")");
}

}  // namespace

uint32_t serialized_shape_count(std::string_view bytes, const std::string& name) {
    return uint32_t(dictionary(bytes, name).offsets.size());
}

TriangleMesh parse_serialized(std::string_view b, uint32_t index, const std::string& name) {
    const Dictionary d = dictionary(b, name);
    if (index >= d.offsets.size())
        fail(name, "shapeIndex " + std::to_string(index) + " is out of range: the file holds " +
                       std::to_string(d.offsets.size()) + " shape" + (d.offsets.size() == 1 ? "" : "s"));
    const uint64_t begin = d.offsets[index];
    const uint64_t end = index + 1 < d.offsets.size() ? d.offsets[index + 1] : d.end;
    const std::string what = name + ": shape " + std::to_string(index);
    if (little<uint16_t>(b.data() + begin) != kFormatTag || little<uint16_t>(b.data() + begin + 2) != d.version)
        fail(what, "corrupt serialized mesh: no format tag and version at offset " + std::to_string(begin));
    const std::string_view stream = b.substr(size_t(begin + 4), size_t(end - begin - 4));
    Inflater in(stream, what);

    const uint32_t flags = in.value<uint32_t>("flags");
    // Mitsuba reads doubles where the double-precision flag is set and floats otherwise: files of
    // version 3 (older exporters) carry neither precision flag.
    const bool single = flags & kSingle, dbl = flags & kDouble;
    if (single && dbl) fail(what, "corrupt serialized mesh: flags 0x" + [&] {
        char h[16];
        std::snprintf(h, sizeof h, "%x", flags);
        return std::string(h);
    }() + " give both single and double precision");
    if (d.version == 4) {
        // The shape's name: up to a NUL byte; bounded so that a stream without one fails early.
        for (int i = 0;; ++i) {
            if (i > 65536) fail(what, "corrupt serialized mesh: the shape name has no end");
            if (in.value<char>("shape name") == 0) break;
        }
    }
    const uint64_t nv = in.value<uint64_t>("vertex count");
    const uint64_t nt = in.value<uint64_t>("triangle count");
    const uint64_t real = dbl ? 8 : 4;
    const uint64_t per_vertex =
        real * (3 + (flags & kVertexNormals ? 3 : 0) + (flags & kTexcoords ? 2 : 0) + (flags & kColors ? 3 : 0));
    const bool wide = nv > std::numeric_limits<uint32_t>::max();
    const uint64_t limit = (stream.size() + 64) * kMaxInflateRatio;
    if (nv == 0 || nt == 0 || nv > limit / per_vertex || nt > limit / (3 * (wide ? 8 : 4)) ||
        nv * per_vertex + nt * 3 * (wide ? 8 : 4) > limit)
        fail(what, "corrupt serialized mesh: " + std::to_string(nv) + " vertices and " + std::to_string(nt) +
                       " triangles cannot come from " + std::to_string(stream.size()) + " compressed bytes");
    if (wide) fail(what, "more than 2^32 - 1 vertices are not supported");

    TriangleMesh m;
    m.face_normals = flags & kFaceNormals;
    m.positions.resize(size_t(nv));
    read_reals(in, &m.positions[0].x, size_t(3 * nv), dbl, "positions", what);
    if (flags & kVertexNormals) {
        m.normals.resize(size_t(nv));
        read_reals(in, &m.normals[0].x, size_t(3 * nv), dbl, "normals", what);
    }
    if (flags & kTexcoords) {
        m.uvs.resize(size_t(nv));
        read_reals(in, &m.uvs[0].x, size_t(2 * nv), dbl, "texture coordinates", what);
    }
    if (flags & kColors) {
        // Not used by iris; read through a small buffer.
        char buf[16384];
        for (uint64_t left = nv * 3 * real; left > 0;) {
            const size_t n = size_t(std::min<uint64_t>(left, sizeof buf));
            in.read(buf, n, "vertex colours");
            left -= n;
        }
    }
    m.indices.resize(size_t(3 * nt));
    in.read(m.indices.data(), m.indices.size() * 4, "triangle indices");
    for (size_t i = 0; i < m.indices.size(); ++i) {
        if constexpr (std::endian::native == std::endian::big)
            m.indices[i] = little<uint32_t>(reinterpret_cast<const char*>(&m.indices[i]));
        if (m.indices[i] >= nv)
            fail(what, "triangle " + std::to_string(i / 3) + " refers to vertex " + std::to_string(m.indices[i]) +
                           " but the shape has " + std::to_string(nv));
    }
    return m;
}

std::string serialize_shape(const TriangleMesh& mesh, const std::string& shape_name, bool double_precision,
                            int version) {
    if (version != 3 && version != 4) throw MeshFileError("serialize_shape: version 3 or 4");
    if (version == 3 && double_precision) throw MeshFileError("serialize_shape: version 3 is single precision");
    std::string raw;
    uint32_t flags = version == 3 ? 0 : double_precision ? kDouble : kSingle;
    auto real = [&](float v) {
        if (double_precision) put_little(&raw, double(v));
        else put_little(&raw, v);
    };
    if (!mesh.normals.empty()) flags |= kVertexNormals;
    if (!mesh.uvs.empty()) flags |= kTexcoords;
    if (mesh.face_normals) flags |= kFaceNormals;
    put_little(&raw, flags);
    if (version == 4) {
        raw.append(shape_name);
        raw.push_back('\0');
    }
    put_little(&raw, uint64_t(mesh.positions.size()));
    put_little(&raw, uint64_t(mesh.indices.size() / 3));
    for (Vec3 p : mesh.positions)
        for (int k = 0; k < 3; ++k) real(p[k]);
    for (Vec3 n : mesh.normals)
        for (int k = 0; k < 3; ++k) real(n[k]);
    for (Vec2 t : mesh.uvs) {
        real(t.x);
        real(t.y);
    }
    for (uint32_t i : mesh.indices) put_little(&raw, i);
    uLongf size = compressBound(uLong(raw.size()));
    std::string out;
    put_little(&out, kFormatTag);
    put_little(&out, uint16_t(version));
    const size_t head = out.size();
    out.resize(head + size);
    if (compress2(reinterpret_cast<Bytef*>(&out[head]), &size, reinterpret_cast<const Bytef*>(raw.data()),
                  uLong(raw.size()), Z_DEFAULT_COMPRESSION) != Z_OK)
        throw MeshFileError("serialize_shape: zlib failed");
    out.resize(head + size);
    return out;
}

std::string serialized_dictionary(const std::vector<size_t>& shape_sizes, int version) {
    std::string out;
    uint64_t offset = 0;
    for (size_t s : shape_sizes) {
        if (version == 3) put_little(&out, uint32_t(offset));
        else put_little(&out, offset);
        offset += s;
    }
    put_little(&out, uint32_t(shape_sizes.size()));
    return out;
}

}  // namespace iris
