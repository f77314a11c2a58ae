// The HDF5 side of the stage files, through the HDF5 C API (simpler to make exception-safe than the
// C++ one: every handle is owned by an Id below, and every failing call becomes a StageFileError).
#include "formats/hdf5_util.h"

#include "formats/atomic_file.h"
#include "formats/hdf5_wrappers.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <new>

namespace iris {
namespace {

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

// ---- Writer ----------------------------------------------------------------------------------------

namespace h5 {
namespace {

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
    if (!h5::read_string_attribute(r.file.get(), "format", &v, &error))
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
