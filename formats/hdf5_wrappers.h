// The generic HDF5 toolkit under the stage files (formats/hdf5_util.cpp): handle ownership, error
// texts, file access, scalar attributes, and the parallel chunk codec (hdf5_chunks.cpp). Internal to
// formats/: it includes <hdf5.h>, which hdf5_util.h keeps away from the tools.
#pragma once

#include <hdf5.h>

#include <cstddef>
#include <string>

namespace iris::h5 {

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

// The text with line breaks turned into spaces and trailing spaces removed (messages are one line).
std::string one_line(std::string s);

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

// The most specific message on HDF5's error stack (e.g. "truncated file: eof = 2048, ..."). Must be
// called straight after the failing call: the next API call clears the stack.
std::string hdf5_detail();

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
Id file_access();

// "a" or "an" before `word`.
const char* an(const std::string& word);
// "(3,)" or "(30, 3)".
std::string shape_text(const hsize_t* dims, int rank);

// ---- scalar attributes (hdf5_wrappers.cpp) ----
// Writes a scalar attribute of `file_type` from memory of `mem_type`. Returns false on failure (the
// caller adds the name and throws).
bool write_scalar_attribute(hid_t loc, const char* name, hid_t file_type, hid_t mem_type, const void* value);
// Strings are variable-length UTF-8: h5py reads them as str (fixed-length ones arrive as bytes).
bool write_string_attribute(hid_t loc, const char* name, const std::string& value);
// Reading: a missing attribute, a non-scalar one or one of the wrong class is reported in *error.
Id open_attribute(hid_t loc, const char* name, H5T_class_t* cls, std::string* error);
// A string attribute, variable- or fixed-length.
bool read_string_attribute(hid_t loc, const char* name, std::string* out, std::string* error);
// Numeric attribute read through HDF5's conversion into `mem_type`; `allow_float` accepts float
// attributes (for doubles), otherwise only integers are accepted.
bool read_numeric_attribute(hid_t loc, const char* name, hid_t mem_type, bool allow_float, void* out,
                            std::string* error);

// ---- the parallel chunk codec (hdf5_chunks.cpp) ----
// Writes `rows` rows of `row_bytes` bytes (elements of `es` bytes) into chunked dataset `ds` whose
// chunks hold `chunk_rows` rows and whose filters are [shuffle, deflate(kDeflateLevel)].
bool write_chunks_parallel(hid_t ds, const unsigned char* data, size_t rows, size_t row_bytes, size_t es,
                           size_t chunk_rows);
// Reads dataset `ds` of `rows` rows of `row_bytes` bytes into `out` in parallel if it was stored the
// way write_chunks_parallel stores it (chunked by whole rows, [shuffle, deflate], file type equal to
// `mem_type`, every chunk present and fully filtered). Returns false, having possibly written part of
// `out`, for anything else; the caller then reads it with H5Dread, which handles every layout.
bool read_chunks_parallel(hid_t ds, hid_t mem_type, unsigned char* out, size_t rows, size_t row_bytes);

}  // namespace iris::h5
