// The HDF5 side of the stage files, through the HDF5 C API (simpler to make exception-safe than the
// C++ one: every handle is owned by an Id below, and every failing call becomes a StageFileError).
#include "formats/hdf5_util.h"

#include "formats/atomic_file.h"

#include <fcntl.h>
#include <hdf5.h>
#include <tbb/parallel_for.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <new>

namespace iris {
namespace {

// Datasets smaller than this are stored contiguously: chunk indexing and filters cost more than they
// save on a few kilobytes (and a chunked layout cannot describe an empty fixed-size dataset).
constexpr size_t kChunkThresholdBytes = 64 * 1024;
// Chunk size aimed for: large enough for deflate to find repetition, below HDF5's default 1 MiB
// chunk cache so a reader that reads row ranges keeps whole chunks cached.
constexpr size_t kChunkTargetBytes = 256 * 1024;
// Deflate level. Measured (one thread) on 1M photons in a box (48 MB raw) and a 20000-cache R=16 atlas
// (42 MB raw): level 1 gives 22.5 MB / 11.1 MB in 2.2 s / 1.2 s of compression, level 4 21.4 MB /
// 9.4 MB in 3.8 s / 1.8 s. Level 1 keeps most of the gain for 60 % of the time, and writing the
// photons must not cost more than tracing them.
constexpr int kDeflateLevel = 1;
// Chunks compressed or decompressed per parallel batch (bounds the memory held at once to ~16 MiB).
constexpr size_t kChunkBatch = 64;

std::string one_line(std::string s) {
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

// Switches off HDF5's automatic error-stack printing for the guard's lifetime and restores whatever
// the program had before. In thread-safe HDF5 builds (Debian's is one) the setting is per thread, so
// the guard must live on the thread that makes the calls; Writer and Reader hold one each.
class QuietHdf5 {
public:
    QuietHdf5() {
        H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
        H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    }
    ~QuietHdf5() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
    QuietHdf5(const QuietHdf5&) = delete;
    QuietHdf5& operator=(const QuietHdf5&) = delete;

private:
    H5E_auto2_t func_ = nullptr;
    void* data_ = nullptr;
};

herr_t innermost_error(unsigned, const H5E_error2_t* err, void* out) {
    auto* s = static_cast<std::string*>(out);
    if (s->empty() && err && err->desc && *err->desc) *s = err->desc;
    return 0;
}

// The most specific message on HDF5's error stack (e.g. "truncated file: eof = 2048, ..."). Must be
// called straight after the failing call: the next API call clears the stack.
std::string hdf5_detail() {
    std::string s;
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, innermost_error, &s);
    return s.empty() ? std::string() : " (HDF5: " + one_line(s) + ")";
}

// Owns one HDF5 identifier and closes it with the matching H5?close.
class Id {
public:
    Id() = default;
    Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    ~Id() { reset(); }
    Id(Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
    Id& operator=(Id&& o) noexcept {
        if (this != &o) {
            reset();
            id_ = o.id_;
            close_ = o.close_;
            o.id_ = H5I_INVALID_HID;
        }
        return *this;
    }
    Id(const Id&) = delete;
    Id& operator=(const Id&) = delete;
    // Returns the close call's status (< 0: failed), so writers can notice a failed final flush.
    herr_t reset() {
        herr_t r = 0;
        if (id_ >= 0 && close_) r = close_(id_);
        id_ = H5I_INVALID_HID;
        return r;
    }
    hid_t get() const { return id_; }
    bool valid() const { return id_ >= 0; }

private:
    hid_t id_ = H5I_INVALID_HID;
    herr_t (*close_)(hid_t) = nullptr;
};

// File access: close everything still open with the file (STRONG: a leaked handle cannot keep a
// half-written file open), and don't fail where the file system has no locks (NFS, some containers).
Id file_access() {
    Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    if (fapl.valid()) {
        H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
#if H5_VERSION_GE(1, 10, 7)
        H5Pset_file_locking(fapl.get(), true, true);
#endif
    }
    return fapl;
}

// UTC now, ISO 8601. SOURCE_DATE_EPOCH (the reproducible-builds convention) overrides the clock, so
// two runs with the same inputs can produce byte-identical files when a test or a build wants that.
std::string iso_time_now() {
    std::time_t t = std::time(nullptr);
    if (const char* e = std::getenv("SOURCE_DATE_EPOCH")) {
        char* end = nullptr;
        long long v = std::strtoll(e, &end, 10);
        if (end != e && *end == '\0' && v >= 0) t = std::time_t(v);
    }
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

const char* an(const std::string& word) {
    return !word.empty() && std::strchr("aeiouAEIOU", word[0]) ? "an" : "a";
}

std::string shape_text(const hsize_t* dims, int rank) {
    std::string s = "(";
    for (int i = 0; i < rank; ++i) s += (i ? ", " : "") + std::to_string(dims[i]);
    return s + (rank == 1 ? ",)" : ")");
}

// ---- parallel chunk codec ---------------------------------------------------------------------------
//
// HDF5 runs filters on one thread: deflating a million photons took 2.5 s there, more than tracing them.
// So large datasets are encoded here, chunk by chunk in parallel (TBB, honouring the tool's thread
// limit), with exactly what HDF5's own shuffle + deflate filters produce, and stored with
// H5Dwrite_chunk; reading does the reverse with H5Dread_chunk. The files are ordinary shuffle+deflate
// datasets: h5dump, h5py and plain H5Dread read them (the tests check this both ways). Each chunk
// is encoded independently and written in order, so the bytes do not depend on the thread count.

// HDF5's shuffle filter (H5Zshuffle.c) on one chunk of n elements of `es` bytes: byte j of element i
// goes to j * n + i. Elements past `valid` are fill (0): HDF5 stores edge chunks at full size.
void shuffle_chunk(const unsigned char* src, size_t valid, size_t n, size_t es, unsigned char* dst) {
    for (size_t j = 0; j < es; ++j) {
        unsigned char* d = dst + j * n;
        for (size_t i = 0; i < valid; ++i) d[i] = src[i * es + j];
        std::fill(d + valid, d + n, 0);
    }
}

// Inverse of shuffle_chunk for the first `valid` elements.
void unshuffle_chunk(const unsigned char* src, size_t valid, size_t n, size_t es, unsigned char* dst) {
    for (size_t j = 0; j < es; ++j) {
        const unsigned char* s = src + j * n;
        for (size_t i = 0; i < valid; ++i) dst[i * es + j] = s[i];
    }
}

// Writes `rows` rows of `row_bytes` bytes (elements of `es` bytes) into chunked dataset `ds` whose
// chunks hold `chunk_rows` rows and whose filters are [shuffle, deflate(kDeflateLevel)].
bool write_chunks_parallel(hid_t ds, const unsigned char* data, size_t rows, size_t row_bytes, size_t es,
                           size_t chunk_rows) {
    const size_t n_chunks = (rows + chunk_rows - 1) / chunk_rows;
    const size_t chunk_bytes = chunk_rows * row_bytes, chunk_elems = chunk_bytes / es;
    std::vector<std::vector<unsigned char>> packed(std::min(kChunkBatch, n_chunks));
    for (size_t first = 0; first < n_chunks; first += kChunkBatch) {
        const size_t count = std::min(kChunkBatch, n_chunks - first);
        std::atomic<bool> failed{false};
        tbb::parallel_for(size_t(0), count, [&](size_t b) {
            const size_t r0 = (first + b) * chunk_rows, nr = std::min(chunk_rows, rows - r0);
            std::vector<unsigned char> shuffled(chunk_bytes);
            shuffle_chunk(data + r0 * row_bytes, nr * row_bytes / es, chunk_elems, es, shuffled.data());
            uLongf size = compressBound(uLong(chunk_bytes));
            packed[b].resize(size);
            // compress2 writes the zlib stream HDF5's deflate filter writes and inflates.
            if (compress2(packed[b].data(), &size, shuffled.data(), uLong(chunk_bytes), kDeflateLevel) != Z_OK)
                failed = true;
            packed[b].resize(size);
        });
        if (failed) return false;
        for (size_t b = 0; b < count; ++b) {
            const hsize_t offset[2] = {hsize_t((first + b) * chunk_rows), 0};
            // filter mask 0: every filter of the pipeline was applied to this chunk.
            if (H5Dwrite_chunk(ds, H5P_DEFAULT, 0, offset, packed[b].size(), packed[b].data()) < 0) return false;
        }
    }
    return true;
}

// Reads dataset `ds` of `rows` rows of `row_bytes` bytes into `out` in parallel if it was stored the
// way write_chunks_parallel stores it (chunked by whole rows, [shuffle, deflate], file type equal to
// `mem_type`, every chunk present and fully filtered). Returns false, having possibly written part of
// `out`, for anything else; the caller then reads it with H5Dread, which handles every layout.
bool read_chunks_parallel(hid_t ds, hid_t mem_type, unsigned char* out, size_t rows, size_t row_bytes) {
    Id dcpl(H5Dget_create_plist(ds), H5Pclose);
    Id ftype(H5Dget_type(ds), H5Tclose);
    if (!dcpl.valid() || !ftype.valid() || H5Pget_layout(dcpl.get()) != H5D_CHUNKED) return false;
    if (H5Tequal(ftype.get(), mem_type) <= 0 || H5Pget_nfilters(dcpl.get()) != 2) return false;
    const H5Z_filter_t expected[2] = {H5Z_FILTER_SHUFFLE, H5Z_FILTER_DEFLATE};
    for (unsigned f = 0; f < 2; ++f) {
        unsigned flags = 0;
        size_t n_cd = 0;
        if (H5Pget_filter2(dcpl.get(), f, &flags, &n_cd, nullptr, 0, nullptr, nullptr) != expected[f]) return false;
    }
    const size_t es = H5Tget_size(ftype.get());
    hsize_t chunk[H5S_MAX_RANK] = {};
    const int rank = H5Pget_chunk(dcpl.get(), H5S_MAX_RANK, chunk);
    if (rank < 1 || rank > 2 || es == 0 || row_bytes % es != 0) return false;
    if (rank == 2 && chunk[1] * es != row_bytes) return false;  // chunks must span whole rows
    if (rank == 1 && es != row_bytes) return false;
    const size_t chunk_rows = size_t(chunk[0]);
    if (chunk_rows == 0) return false;
    const size_t n_chunks = (rows + chunk_rows - 1) / chunk_rows;
    const size_t chunk_bytes = chunk_rows * row_bytes, chunk_elems = chunk_bytes / es;
    std::vector<std::vector<unsigned char>> packed(std::min(kChunkBatch, n_chunks));
    for (size_t first = 0; first < n_chunks; first += kChunkBatch) {
        const size_t count = std::min(kChunkBatch, n_chunks - first);
        for (size_t b = 0; b < count; ++b) {
            const hsize_t offset[2] = {hsize_t((first + b) * chunk_rows), 0};
            hsize_t nbytes = 0;
            uint32_t mask = 0;
            if (H5Dget_chunk_storage_size(ds, offset, &nbytes) < 0 || nbytes == 0) return false;
            packed[b].resize(size_t(nbytes));
            if (H5Dread_chunk(ds, H5P_DEFAULT, offset, &mask, packed[b].data()) < 0 || mask != 0) return false;
        }
        std::atomic<bool> failed{false};
        tbb::parallel_for(size_t(0), count, [&](size_t b) {
            const size_t r0 = (first + b) * chunk_rows, nr = std::min(chunk_rows, rows - r0);
            std::vector<unsigned char> shuffled(chunk_bytes);
            uLongf size = uLongf(chunk_bytes);
            if (uncompress(shuffled.data(), &size, packed[b].data(), uLong(packed[b].size())) != Z_OK ||
                size != chunk_bytes) {
                failed = true;
                return;
            }
            unshuffle_chunk(shuffled.data(), nr * row_bytes / es, chunk_elems, es, out + r0 * row_bytes);
        });
        if (failed) return false;
    }
    return true;
}

}  // namespace

// ---- validators ------------------------------------------------------------------------------------

namespace h5 {

std::string check_rows(const char* name, size_t rows, const char* reference, size_t expected) {
    if (rows == expected) return {};
    return "dataset '" + std::string(name) + "' has " + std::to_string(rows) + " rows but '" + reference + "' has " +
           std::to_string(expected);
}

std::string check_finite(const char* name, const std::vector<Vec3>& v) {
    for (size_t i = 0; i < v.size(); ++i)
        if (!is_finite(v[i])) return "dataset '" + std::string(name) + "' has a non-finite value in row " + std::to_string(i);
    return {};
}

std::string check_finite(const char* name, const std::vector<float>& v) {
    for (size_t i = 0; i < v.size(); ++i)
        if (!std::isfinite(v[i]))
            return "dataset '" + std::string(name) + "' has a non-finite value at element " + std::to_string(i);
    return {};
}

std::string check_unit(const char* name, const std::vector<Vec3>& v) {
    if (std::string e = check_finite(name, v); !e.empty()) return e;
    for (size_t i = 0; i < v.size(); ++i) {
        float len = length(v[i]);
        if (!(std::abs(len - 1.0f) <= 1e-3f))
            return "dataset '" + std::string(name) + "' row " + std::to_string(i) + " is not a unit vector (length " +
                   std::to_string(len) + ")";
    }
    return {};
}

}  // namespace h5

// ---- attribute helpers (file-local) ----------------------------------------------------------------

namespace {

// Writes a scalar attribute of `file_type` from memory of `mem_type`. Returns false on failure (the
// caller adds the name and throws).
bool write_scalar_attribute(hid_t loc, const char* name, hid_t file_type, hid_t mem_type, const void* value) {
    Id space(H5Screate(H5S_SCALAR), H5Sclose);
    if (!space.valid()) return false;
    Id attr(H5Acreate2(loc, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) return false;
    if (H5Awrite(attr.get(), mem_type, value) < 0) return false;
    return attr.reset() >= 0;
}

// Strings are variable-length UTF-8: h5py reads them as str (fixed-length ones arrive as bytes).
bool write_string_attribute(hid_t loc, const char* name, const std::string& value) {
    Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    if (!type.valid() || H5Tset_size(type.get(), H5T_VARIABLE) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
        return false;
    const char* p = value.c_str();
    return write_scalar_attribute(loc, name, type.get(), type.get(), &p);
}

// Reading: a missing attribute, a non-scalar one or one of the wrong class is reported in *error.
Id open_attribute(hid_t loc, const char* name, H5T_class_t* cls, std::string* error) {
    htri_t exists = H5Aexists(loc, name);
    if (exists <= 0) {
        *error = "missing attribute '" + std::string(name) + "'";
        return {};
    }
    Id attr(H5Aopen(loc, name, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) {
        *error = "cannot open attribute '" + std::string(name) + "'" + hdf5_detail();
        return {};
    }
    Id space(H5Aget_space(attr.get()), H5Sclose);
    if (!space.valid() || H5Sget_simple_extent_npoints(space.get()) != 1) {
        *error = "attribute '" + std::string(name) + "' is not a single value";
        return {};
    }
    Id type(H5Aget_type(attr.get()), H5Tclose);
    *cls = type.valid() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
    return attr;
}

bool read_string_attribute(hid_t loc, const char* name, std::string* out, std::string* error) {
    H5T_class_t cls = H5T_NO_CLASS;
    Id attr = open_attribute(loc, name, &cls, error);
    if (!attr.valid()) return false;
    if (cls != H5T_STRING) {
        *error = "attribute '" + std::string(name) + "' is not a string";
        return false;
    }
    Id ftype(H5Aget_type(attr.get()), H5Tclose);
    htri_t vlen = H5Tis_variable_str(ftype.get());
    if (vlen > 0) {
        Id mtype(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(mtype.get(), H5T_VARIABLE);
        H5Tset_cset(mtype.get(), H5Tget_cset(ftype.get()));
        char* p = nullptr;
        if (H5Aread(attr.get(), mtype.get(), &p) < 0) {
            *error = "cannot read attribute '" + std::string(name) + "'" + hdf5_detail();
            return false;
        }
        *out = p ? p : "";
        H5free_memory(p);
        return true;
    }
    // Fixed-length (as some writers, e.g. h5py with numpy bytes, produce): NUL-terminated or padded.
    size_t size = H5Tget_size(ftype.get());
    std::string buf(size + 1, '\0');
    Id mtype(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mtype.get(), size + 1);
    H5Tset_cset(mtype.get(), H5Tget_cset(ftype.get()));
    if (H5Aread(attr.get(), mtype.get(), buf.data()) < 0) {
        *error = "cannot read attribute '" + std::string(name) + "'" + hdf5_detail();
        return false;
    }
    buf.resize(std::strlen(buf.c_str()));
    while (!buf.empty() && buf.back() == ' ') buf.pop_back();  // H5T_STR_SPACEPAD
    *out = buf;
    return true;
}

// Numeric attribute read through HDF5's conversion into `mem_type`; `allow_float` accepts float
// attributes (for doubles), otherwise only integers are accepted.
bool read_numeric_attribute(hid_t loc, const char* name, hid_t mem_type, bool allow_float, void* out,
                            std::string* error) {
    H5T_class_t cls = H5T_NO_CLASS;
    Id attr = open_attribute(loc, name, &cls, error);
    if (!attr.valid()) return false;
    if (!(cls == H5T_INTEGER || (allow_float && cls == H5T_FLOAT))) {
        *error = "attribute '" + std::string(name) + "' is not " + (allow_float ? "a number" : "an integer");
        return false;
    }
    if (H5Aread(attr.get(), mem_type, out) < 0) {
        *error = "cannot read attribute '" + std::string(name) + "'" + hdf5_detail();
        return false;
    }
    return true;
}

struct ParameterScan {
    std::map<std::string, double>* out;
    std::string error;
};

herr_t read_parameter(hid_t loc, const char* name, const H5A_info_t*, void* data) {
    auto* scan = static_cast<ParameterScan*>(data);
    double v = 0;
    if (!read_numeric_attribute(loc, name, H5T_NATIVE_DOUBLE, true, &v, &scan->error)) return -1;
    (*scan->out)[name] = v;
    return 0;
}

}  // namespace

// ---- Writer ----------------------------------------------------------------------------------------

namespace h5 {

struct Writer::Impl {
    QuietHdf5 quiet;
    std::string path;
    std::unique_ptr<AtomicFile> out;  // the temporary file; renamed into place by commit()
    Id file;

    // Any failure, committed or not, ends with the temporary file removed (by ~AtomicFile, after HDF5
    // has closed it): the final path either holds the complete new file or whatever it held before.
    ~Impl() { file.reset(); }

    [[noreturn]] void fail(const std::string& message) const { throw StageFileError(path + ": " + one_line(message)); }

    void write_dataset(const char* name, hid_t file_type, hid_t mem_type, size_t elem_bytes, const void* data,
                       size_t rows, size_t cols, const char* units, const char* description) {
        const int rank = cols ? 2 : 1;
        const hsize_t dims[2] = {hsize_t(rows), hsize_t(cols)};
        Id space(H5Screate_simple(rank, dims, nullptr), H5Sclose);
        Id dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
        if (!space.valid() || !dcpl.valid()) fail("cannot create dataset '" + std::string(name) + "'" + hdf5_detail());
        // No modification times in object headers: the same data gives the same bytes.
        H5Pset_obj_track_times(dcpl.get(), false);
        const size_t row_bytes = elem_bytes * (cols ? cols : 1);
        size_t chunk_rows = 0;
        bool compressed = false;
        if (rows * row_bytes >= kChunkThresholdBytes) {
            chunk_rows = std::max<size_t>(1, std::min(rows, kChunkTargetBytes / row_bytes));
            const hsize_t chunk[2] = {hsize_t(chunk_rows), hsize_t(cols)};
            bool ok = H5Pset_chunk(dcpl.get(), rank, chunk) >= 0;
            // Shuffle groups the bytes of equal significance (exponents together), which is what
            // makes float data compress; deflate is in every HDF5 build h5py and h5dump ship with,
            // but if this one lacks it the data is still written, uncompressed.
            compressed = ok && H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0;
            if (compressed)
                ok = H5Pset_shuffle(dcpl.get()) >= 0 && H5Pset_deflate(dcpl.get(), unsigned(kDeflateLevel)) >= 0;
            if (!ok) fail("cannot set up compression for dataset '" + std::string(name) + "'" + hdf5_detail());
        }
        Id ds(H5Dcreate2(file.get(), name, file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
        if (!ds.valid()) fail("cannot create dataset '" + std::string(name) + "'" + hdf5_detail());
        // The file types are little-endian; the parallel path stores memory bytes as they are.
        const bool raw_ok = H5Tequal(file_type, mem_type) > 0;
        if (compressed && raw_ok) {
            if (!write_chunks_parallel(ds.get(), static_cast<const unsigned char*>(data), rows, row_bytes, elem_bytes,
                                       chunk_rows))
                fail("cannot write dataset '" + std::string(name) + "'" + hdf5_detail());
        } else if (rows > 0 && H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
            fail("cannot write dataset '" + std::string(name) + "'" + hdf5_detail());
        }
        if (!write_string_attribute(ds.get(), "units", units ? units : "") ||
            !write_string_attribute(ds.get(), "description", description ? description : ""))
            fail("cannot write the attributes of dataset '" + std::string(name) + "'" + hdf5_detail());
        if (ds.reset() < 0) fail("cannot write dataset '" + std::string(name) + "'" + hdf5_detail());
    }
};

Writer::Writer(const std::string& path, const std::string& format, int version, const std::string& scene_fingerprint,
               const Provenance& provenance)
    : impl_(std::make_unique<Impl>()) {
    Impl& w = *impl_;
    w.path = path;
    // The contract says every stage file names its scene: an empty one would disable the check that
    // stops a stage from mixing files made for different scenes.
    if (scene_fingerprint.empty()) w.fail("refusing to write: no scene fingerprint given");
    if (provenance.tool.empty()) w.fail("refusing to write: provenance has no tool name");
    for (const auto& [name, value] : provenance.parameters) {
        if (name.empty()) w.fail("refusing to write: a parameter has an empty name");
        if (!std::isfinite(value)) w.fail("refusing to write: parameter '" + name + "' is not finite");
    }

    // Create the file with open() first: its errno says clearly why a directory is unusable, where
    // HDF5 would bury it in a stack of messages. HDF5 then opens the same temporary file by name.
    try {
        w.out = std::make_unique<AtomicFile>(path);
    } catch (const std::exception& e) {
        throw StageFileError(one_line(e.what()));
    }
    const std::string& tmp = w.out->temp_path();
    Id fapl = file_access();
    w.file = Id(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
    if (!w.file.valid()) w.fail("cannot create HDF5 file '" + tmp + "'" + hdf5_detail());

    attribute_string("format", format);
    attribute_i32("format_version", version);
    attribute_string("scene_fingerprint", scene_fingerprint);
    attribute_string("tool", provenance.tool);
    attribute_string("tool_version", provenance.tool_version);
    attribute_string("command_line", provenance.command_line);
    attribute_u64("seed", provenance.seed);
    attribute_string("inputs", provenance.inputs);
    attribute_string("created", iso_time_now());

    Id gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
    if (gcpl.valid()) H5Pset_obj_track_times(gcpl.get(), false);
    Id group(H5Gcreate2(w.file.get(), "parameters", H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
    if (!group.valid()) w.fail("cannot create group 'parameters'" + hdf5_detail());
    for (const auto& [name, value] : provenance.parameters)
        if (!write_scalar_attribute(group.get(), name.c_str(), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value))
            w.fail("cannot write parameter '" + name + "'" + hdf5_detail());
}

Writer::~Writer() = default;

void Writer::fail(const std::string& message) const { impl_->fail(message); }

void Writer::attribute_i32(const char* name, int32_t value) {
    if (!write_scalar_attribute(impl_->file.get(), name, H5T_STD_I32LE, H5T_NATIVE_INT32, &value))
        fail("cannot write attribute '" + std::string(name) + "'" + hdf5_detail());
}

void Writer::attribute_u64(const char* name, uint64_t value) {
    if (!write_scalar_attribute(impl_->file.get(), name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &value))
        fail("cannot write attribute '" + std::string(name) + "'" + hdf5_detail());
}

void Writer::attribute_f64(const char* name, double value) {
    if (!write_scalar_attribute(impl_->file.get(), name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value))
        fail("cannot write attribute '" + std::string(name) + "'" + hdf5_detail());
}

void Writer::attribute_string(const char* name, const std::string& value) {
    if (!write_string_attribute(impl_->file.get(), name, value))
        fail("cannot write attribute '" + std::string(name) + "'" + hdf5_detail());
}

void Writer::dataset(const char* name, const std::vector<Vec3>& v, const char* units, const char* description) {
    // Copied into a flat array rather than reinterpreting Vec3* as float* (no aliasing assumptions).
    std::vector<float> flat(v.size() * 3);
    for (size_t i = 0; i < v.size(); ++i)
        for (int c = 0; c < 3; ++c) flat[3 * i + c] = v[i][c];
    impl_->write_dataset(name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, sizeof(float), flat.data(), v.size(), 3, units,
                         description);
}

void Writer::dataset(const char* name, const std::vector<RGB>& v, const char* units, const char* description) {
    std::vector<float> flat(v.size() * 3);
    for (size_t i = 0; i < v.size(); ++i)
        for (int c = 0; c < 3; ++c) flat[3 * i + c] = v[i][c];
    impl_->write_dataset(name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, sizeof(float), flat.data(), v.size(), 3, units,
                         description);
}

void Writer::dataset(const char* name, const std::vector<float>& v, size_t cols, const char* units,
                     const char* description) {
    if (cols && v.size() % cols != 0)
        fail("dataset '" + std::string(name) + "': " + std::to_string(v.size()) + " values do not fill rows of " +
             std::to_string(cols));
    impl_->write_dataset(name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, sizeof(float), v.data(), cols ? v.size() / cols : v.size(),
                         cols, units, description);
}

void Writer::dataset(const char* name, const std::vector<uint8_t>& v, const char* units, const char* description) {
    impl_->write_dataset(name, H5T_STD_U8LE, H5T_NATIVE_UINT8, 1, v.data(), v.size(), 0, units, description);
}

void Writer::dataset(const char* name, const std::vector<uint32_t>& v, const char* units, const char* description) {
    impl_->write_dataset(name, H5T_STD_U32LE, H5T_NATIVE_UINT32, 4, v.data(), v.size(), 0, units, description);
}

void Writer::commit() {
    Impl& w = *impl_;
    // Closing writes the remaining metadata; a failure here (disk full) means an incomplete file.
    if (w.file.reset() < 0) fail("cannot finish writing '" + w.out->temp_path() + "'" + hdf5_detail());
    // (fsync on our descriptor flushes what HDF5 wrote through its own: both name the same file.)
    try {
        w.out->commit();
    } catch (const std::exception& e) {
        throw StageFileError(one_line(e.what()));
    }
}

// ---- Reader ----------------------------------------------------------------------------------------

struct Reader::Impl {
    QuietHdf5 quiet;
    std::string path;
    Id file;
    StageHeader header;

    [[noreturn]] void fail(const std::string& message) const { throw StageFileError(path + ": " + one_line(message)); }

    // Opens `path` read-only with messages for the three ways that fails before any iris check.
    void open() {
        int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) fail(std::string("cannot open: ") + std::strerror(errno));
        ::close(fd);
#if H5_VERSION_GE(1, 12, 0)
        htri_t is_hdf5 = H5Fis_accessible(path.c_str(), H5P_DEFAULT);
#else
        htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
#endif
        // The HDF5 signature sits in the first bytes, so a truncated file still has it: HDF5 then
        // fails the open because the file is shorter than its superblock says.
        if (is_hdf5 <= 0) fail("not an HDF5 file");
        Id fapl = file_access();
        file = Id(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
        if (!file.valid()) fail("damaged or truncated HDF5 file, cannot open it" + hdf5_detail());
    }

    std::string string_attribute(hid_t loc, const char* name) const {
        std::string v, error;
        if (!read_string_attribute(loc, name, &v, &error)) fail(error);
        return v;
    }

    // Reads the common root attributes and checks kind, version and fingerprint, in that order (so
    // that a wrong file is reported as such before anything about its contents).
    void read_header(const std::string& format, int version, const std::string& expected_fingerprint) {
        hid_t root = file.get();
        {
            std::string v, error;
            if (!read_string_attribute(root, "format", &v, &error))
                fail(H5Aexists(root, "format") > 0 ? error : "not an iris stage file (no 'format' attribute)");
            header.format = v;
        }
        if (!format.empty() && header.format != format)
            fail("is " + std::string(an(header.format)) + " " + header.format + " file, expected " + format);
        int64_t v = 0;
        std::string error;
        if (!read_numeric_attribute(root, "format_version", H5T_NATIVE_INT64, false, &v, &error)) fail(error);
        if (v != version)
            fail("unknown format_version " + std::to_string(v) + " of " + header.format + " (this iris reads version " +
                 std::to_string(version) + ")");
        header.format_version = int(v);
        header.scene_fingerprint = string_attribute(root, "scene_fingerprint");
        if (!expected_fingerprint.empty() && header.scene_fingerprint != expected_fingerprint)
            fail("made for another scene (fingerprint " + header.scene_fingerprint + ", this scene is " +
                 expected_fingerprint + ")");
        Provenance& p = header.provenance;
        p.tool = string_attribute(root, "tool");
        p.tool_version = string_attribute(root, "tool_version");
        p.command_line = string_attribute(root, "command_line");
        p.inputs = string_attribute(root, "inputs");
        if (!read_numeric_attribute(root, "seed", H5T_NATIVE_UINT64, false, &p.seed, &error)) fail(error);
        header.created = string_attribute(root, "created");
        // /parameters is informational; a file without it (hand-made with h5py) just has none.
        if (H5Lexists(root, "parameters", H5P_DEFAULT) > 0) {
            Id group(H5Gopen2(root, "parameters", H5P_DEFAULT), H5Gclose);
            if (!group.valid()) fail("'parameters' is not a group");
            ParameterScan scan{&p.parameters, {}};
            hsize_t idx = 0;
            if (H5Aiterate2(group.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, read_parameter, &scan) < 0)
                fail(scan.error.empty() ? "cannot read group 'parameters'" + hdf5_detail() : "parameters: " + scan.error);
            for (const auto& [name, value] : p.parameters)
                if (!std::isfinite(value)) fail("parameter '" + name + "' is not finite");
        }
    }

    // Opens dataset `name`, checks its type class and shape ((rows) when cols == 0, else (rows, cols))
    // and reads it converted to `mem_type`.
    template <class T>
    std::vector<T> read(const char* name, hid_t mem_type, H5T_class_t cls, size_t cols, size_t* rows_out) const {
        if (H5Lexists(file.get(), name, H5P_DEFAULT) <= 0) fail("missing dataset '" + std::string(name) + "'");
        Id ds(H5Dopen2(file.get(), name, H5P_DEFAULT), H5Dclose);
        if (!ds.valid()) fail("'" + std::string(name) + "' is not a dataset");
        Id type(H5Dget_type(ds.get()), H5Tclose);
        if (!type.valid() || H5Tget_class(type.get()) != cls)
            fail("dataset '" + std::string(name) + "' is not " + (cls == H5T_FLOAT ? "a float" : "an integer") +
                 " array");
        Id space(H5Dget_space(ds.get()), H5Sclose);
        int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
        hsize_t dims[H5S_MAX_RANK] = {};
        if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims, nullptr);
        const int want_rank = cols ? 2 : 1;
        if (rank != want_rank || (cols && dims[1] != cols)) {
            std::string want = cols ? "(n, " + std::to_string(cols) + ")" : "(n,)";
            fail("dataset '" + std::string(name) + "' has shape " + (rank >= 0 ? shape_text(dims, rank) : "?") +
                 ", expected " + want);
        }
        const size_t rows = size_t(dims[0]);
        // Refuse a shape the file cannot hold before allocating memory for it: a damaged dimension
        // (found by fuzzing) asked for 206 GB, which a machine that overcommits memory would try to
        // zero-fill. Every value takes at least one byte and deflate packs at most 1032 bytes into
        // one, so no dataset holds more than 1032 values per byte of the file. (In double: no overflow.)
        hsize_t file_bytes = 0;
        H5Fget_filesize(file.get(), &file_bytes);
        if (double(rows) * double(cols ? cols : 1) > 1032.0 * double(file_bytes))
            fail("dataset '" + std::string(name) + "' has " + std::to_string(dims[0]) +
                 " rows, more than a file of " + std::to_string(file_bytes) + " bytes can hold");
        std::vector<T> out;
        try {
            out.resize(rows * (cols ? cols : 1));
        } catch (const std::bad_alloc&) {
            fail("dataset '" + std::string(name) + "' is too large to load (" + std::to_string(rows) + " rows)");
        }
        if (!out.empty() &&
            !read_chunks_parallel(ds.get(), mem_type, reinterpret_cast<unsigned char*>(out.data()), rows,
                                  sizeof(T) * (cols ? cols : 1)) &&
            H5Dread(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
            fail("cannot read dataset '" + std::string(name) + "'" + hdf5_detail());
        if (rows_out) *rows_out = rows;
        return out;
    }
};

Reader::Reader(const std::string& path, const std::string& format, int version, const std::string& expected_fingerprint)
    : impl_(std::make_unique<Impl>()) {
    impl_->path = path;
    impl_->open();
    impl_->read_header(format, version, expected_fingerprint);
}

Reader::~Reader() = default;

const StageHeader& Reader::header() const { return impl_->header; }
const std::string& Reader::path() const { return impl_->path; }
void Reader::fail(const std::string& message) const { impl_->fail(message); }

int64_t Reader::attribute_int(const char* name) const {
    int64_t v = 0;
    std::string error;
    if (!read_numeric_attribute(impl_->file.get(), name, H5T_NATIVE_INT64, false, &v, &error)) fail(error);
    return v;
}

uint64_t Reader::attribute_uint(const char* name) const {
    uint64_t v = 0;
    std::string error;
    if (!read_numeric_attribute(impl_->file.get(), name, H5T_NATIVE_UINT64, false, &v, &error)) fail(error);
    return v;
}

double Reader::attribute_double(const char* name) const {
    double v = 0;
    std::string error;
    if (!read_numeric_attribute(impl_->file.get(), name, H5T_NATIVE_DOUBLE, true, &v, &error)) fail(error);
    return v;
}

std::string Reader::attribute_string(const char* name) const { return impl_->string_attribute(impl_->file.get(), name); }

std::vector<Vec3> Reader::vec3s(const char* name) const {
    size_t rows = 0;
    std::vector<float> flat = impl_->read<float>(name, H5T_NATIVE_FLOAT, H5T_FLOAT, 3, &rows);
    std::vector<Vec3> out(rows);
    for (size_t i = 0; i < rows; ++i) out[i] = Vec3(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
    return out;
}

std::vector<RGB> Reader::rgbs(const char* name) const {
    size_t rows = 0;
    std::vector<float> flat = impl_->read<float>(name, H5T_NATIVE_FLOAT, H5T_FLOAT, 3, &rows);
    std::vector<RGB> out(rows);
    for (size_t i = 0; i < rows; ++i) out[i] = RGB(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
    return out;
}

std::vector<float> Reader::floats(const char* name, size_t cols, size_t* rows) const {
    return impl_->read<float>(name, H5T_NATIVE_FLOAT, H5T_FLOAT, cols, rows);
}

std::vector<uint8_t> Reader::u8s(const char* name) const {
    return impl_->read<uint8_t>(name, H5T_NATIVE_UINT8, H5T_INTEGER, 0, nullptr);
}

bool Reader::has_dataset(const char* name) const {
    QuietHdf5 quiet;
    return H5Lexists(impl_->file.get(), name, H5P_DEFAULT) > 0;
}

std::vector<uint32_t> Reader::u32s(const char* name) const {
    return impl_->read<uint32_t>(name, H5T_NATIVE_UINT32, H5T_INTEGER, 0, nullptr);
}

}  // namespace h5

// ---- free functions --------------------------------------------------------------------------------

StageHeader read_stage_header(const std::string& path, const std::string& format, int version,
                              const std::string& expected_fingerprint) {
    h5::Reader reader(path, format, version, expected_fingerprint);
    return reader.header();
}

std::string stage_file_format(const std::string& path) {
    h5::Reader::Impl r;
    r.path = path;
    r.open();
    std::string v, error;
    if (!read_string_attribute(r.file.get(), "format", &v, &error))
        r.fail(H5Aexists(r.file.get(), "format") > 0 ? error : "not an iris stage file (no 'format' attribute)");
    return v;
}

std::string file_fingerprint(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw StageFileError(path + ": cannot open: " + std::strerror(errno));
    uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a 64 offset basis
    std::vector<unsigned char> buf(1 << 20);
    size_t n = 0;
    while ((n = std::fread(buf.data(), 1, buf.size(), f)) > 0)
        for (size_t i = 0; i < n; ++i) h = (h ^ buf[i]) * 0x100000001b3ULL;  // FNV-1a 64 prime
    bool failed = std::ferror(f) != 0;
    std::fclose(f);
    if (failed) throw StageFileError(path + ": read error while computing its fingerprint");
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h);
    return hex;
}

}  // namespace iris
