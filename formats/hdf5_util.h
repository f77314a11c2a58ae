// What every iris stage file (photons.h5, caches.h5, atlas.h5) has in common, and the small HDF5
// toolkit the three formats are written with. The layouts themselves are in formats/README.md.
//
// Every stage file carries, as attributes of its root group:
//   format            string  "iris-photon-map" | "iris-cache-points" | "iris-cache-atlas"
//   format_version    int32   the layout version (readers accept exactly the versions they know)
//   scene_fingerprint string  hex digest of the scene the file was made for
//   tool, tool_version, command_line, inputs, created   strings (provenance)
//   seed              uint64
// and a group /parameters whose float64 attributes are the stage's numeric parameters.
//
// Writing is atomic: everything goes to "<path>.tmp-<pid>", which is closed, fsync'ed and renamed
// over <path>; on any failure the temporary file is removed and StageFileError is thrown, so a killed
// or failing stage never leaves a partial file under the final name.
//
// Reading validates before it returns: every problem becomes one StageFileError whose message is a
// single line starting with the path ("photons.h5: made for another scene (...)"). HDF5's own
// error-stack printing is switched off while our calls run, so only that line reaches the user.
//
// This header does not include <hdf5.h>: the HDF5 handles live behind the h5::Writer/h5::Reader
// implementations, so tools that only read and write stage files never see the C API.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/math.h"

namespace iris {

// Thrown for any problem with a stage file; what() is one line, "PATH: message".
struct StageFileError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Who made a file, how, and from what. Written as root attributes (parameters: /parameters).
struct Provenance {
    std::string tool;          // the program, e.g. "trace-photons" (required, non-empty)
    std::string tool_version;  // its version, e.g. IRIS_VERSION
    std::string command_line;  // the command line as the user typed it
    std::string inputs;        // one line per input file: "PATH FINGERPRINT" (see file_fingerprint)
    uint64_t seed = 0;         // the stage's random seed
    // The stage's numeric parameters (photon paths, camera_stride, k, ...), so that a file records the
    // settings that made it. Names must be non-empty; values finite.
    std::map<std::string, double> parameters;
};

// The common root attributes of a stage file, as read back.
struct StageHeader {
    std::string format;             // e.g. "iris-photon-map"
    int format_version = 0;
    std::string scene_fingerprint;  // the scene the file was made for
    Provenance provenance;
    std::string created;            // UTC time of writing, ISO 8601 ("2025-01-31T12:00:00Z")
};

// Reads and checks the root attributes only (cheap: no dataset is loaded). Throws StageFileError if
// the file is not an HDF5 file or is damaged, is not of kind `format`, has another version than
// `version`, or (when expected_fingerprint is not empty) was made for another scene.
StageHeader read_stage_header(const std::string& path, const std::string& format, int version,
                              const std::string& expected_fingerprint = {});

// The `format` attribute of any iris stage file ("what is this file?", for inspection tools).
// Throws StageFileError when the file is not an HDF5 file or has no format attribute.
std::string stage_file_format(const std::string& path);

// Content fingerprint of any file, for Provenance::inputs: 64-bit FNV-1a of its bytes as 16 lower-case
// hex digits. Throws StageFileError when the file cannot be read.
std::string file_fingerprint(const std::string& path);

// Building blocks of formats/*.cpp. Tools use the per-format read_/write_ functions instead.
namespace h5 {

// Texts for the validators below: "" when fine, else a message naming the dataset and row.
std::string check_rows(const char* name, size_t rows, const char* reference, size_t expected);
std::string check_finite(const char* name, const std::vector<Vec3>& v);
std::string check_finite(const char* name, const std::vector<float>& v);
// Finite and of length 1 within 1e-3 (float32 storage of a normalised vector is far more exact).
std::string check_unit(const char* name, const std::vector<Vec3>& v);

// Writes one stage file to "<path>.tmp-<pid>"; commit() renames it into place. Destroying a Writer
// that was not committed (an exception on the way) closes and removes the temporary file.
class Writer {
public:
    // Creates the temporary file and writes the common root attributes and /parameters.
    // Refuses (StageFileError) an empty fingerprint, an empty provenance.tool, non-finite parameters.
    Writer(const std::string& path, const std::string& format, int version, const std::string& scene_fingerprint,
           const Provenance& provenance);
    ~Writer();
    Writer(const Writer&) = delete;
    Writer& operator=(const Writer&) = delete;

    // Root attributes.
    void attribute_i32(const char* name, int32_t value);
    void attribute_u64(const char* name, uint64_t value);
    void attribute_f64(const char* name, double value);
    void attribute_string(const char* name, const std::string& value);

    // Datasets of n rows; each gets string attributes `units` and `description` (for h5dump/h5py
    // readers; iris does not read them). Large datasets are chunked, shuffled and deflate-compressed.
    void dataset(const char* name, const std::vector<Vec3>& v, const char* units, const char* description);  // (n,3) f32
    void dataset(const char* name, const std::vector<RGB>& v, const char* units, const char* description);   // (n,3) f32
    // (rows, cols) float32 from a row-major array of rows*cols values; cols = 0 writes a 1-D (rows) array.
    void dataset(const char* name, const std::vector<float>& v, size_t cols, const char* units,
                 const char* description);
    void dataset(const char* name, const std::vector<uint8_t>& v, const char* units, const char* description);   // (n) u8
    void dataset(const char* name, const std::vector<uint32_t>& v, const char* units, const char* description);  // (n) u32

    // Closes the file, fsyncs it and renames it over the final path. Throws StageFileError.
    void commit();

    // Throws StageFileError("PATH: message").
    [[noreturn]] void fail(const std::string& message) const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// Opens a stage file and checks its header (kind, version, fingerprint, provenance attributes) in the
// constructor; the accessors read and shape-check one attribute or dataset each.
class Reader {
public:
    Reader(const std::string& path, const std::string& format, int version, const std::string& expected_fingerprint);
    ~Reader();
    Reader(const Reader&) = delete;
    Reader& operator=(const Reader&) = delete;

    const StageHeader& header() const;
    const std::string& path() const;

    // Required root attributes; a missing one, or one of the wrong type class, is an error.
    int64_t attribute_int(const char* name) const;
    uint64_t attribute_uint(const char* name) const;
    double attribute_double(const char* name) const;  // float or integer attribute
    std::string attribute_string(const char* name) const;

    // Required datasets. Float datasets may be stored as any float type, integer ones as any integer
    // type (HDF5 converts); the shape must be (n,3) for vectors and (n) for scalars.
    std::vector<Vec3> vec3s(const char* name) const;
    std::vector<RGB> rgbs(const char* name) const;
    // (rows, cols) float array, row-major; cols = 0 expects a 1-D array. *rows receives the row count.
    std::vector<float> floats(const char* name, size_t cols, size_t* rows = nullptr) const;
    std::vector<uint8_t> u8s(const char* name) const;
    // Whether an (optional) dataset exists.
    bool has_dataset(const char* name) const;
    std::vector<uint32_t> u32s(const char* name) const;

    // Throws StageFileError("PATH: message").
    [[noreturn]] void fail(const std::string& message) const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace h5
}  // namespace iris
