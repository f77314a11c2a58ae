// The HDF5 stage files (photons.h5, caches.h5, atlas.h5): round trips, atomic writes, and one clear
// refusal per kind of bad input, for each of the three readers. Files that are broken on purpose are
// made by writing a valid file and then editing it through the HDF5 C API, as a user's script or a
// bug elsewhere would.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <numbers>
#include <regex>
#include <string>
#include <vector>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/photon_map.h"
#include "libcommon/rng.h"

namespace fs = std::filesystem;
using namespace iris;

namespace {

const std::string kFingerprint = "3f2a9c1d5e7b8a60";

// A fresh directory per test, removed with everything in it afterwards.
class TempDir {
public:
    TempDir() {
        std::string tmpl = (fs::temp_directory_path() / "iris-stage-XXXXXX").string();
        if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
        dir_ = tmpl;
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string file(const std::string& name) const { return (dir_ / name).string(); }
    // Names of everything in the directory (to spot left-over temporary files).
    std::vector<std::string> entries() const {
        std::vector<std::string> out;
        for (const auto& e : fs::directory_iterator(dir_)) out.push_back(e.path().filename().string());
        std::sort(out.begin(), out.end());
        return out;
    }
    const fs::path& path() const { return dir_; }

private:
    fs::path dir_;
};

Vec3 random_unit(Rng& rng) {
    float z = 1.0f - 2.0f * rng.next_float();
    float phi = 2.0f * kPi * rng.next_float();
    float r = safe_sqrt(1.0f - z * z);
    return normalize(Vec3(r * std::cos(phi), r * std::sin(phi), z));
}

Vec3 random_point(Rng& rng) {
    return Vec3(10 * rng.next_float() - 5, 10 * rng.next_float() - 5, 10 * rng.next_float() - 5);
}

PhotonMap make_photons(size_t n) {
    Rng rng(1, 0);
    PhotonMap m;
    for (size_t i = 0; i < n; ++i) {
        Vec3 nrm = random_unit(rng), dir = random_unit(rng);
        if (dot(dir, nrm) < 0) dir = -dir;  // the contract: the normal faces the incident side
        m.position.push_back(random_point(rng));
        m.direction.push_back(dir);
        m.normal.push_back(nrm);
        m.power.push_back(RGB(rng.next_float(), rng.next_float(), rng.next_float()) * 1e-3f);
        m.bounces.push_back(uint8_t(i % 5));
        m.caustic.push_back(uint8_t(i % 5 > 1 && i % 3 == 0));
    }
    m.emitted_paths = n * 3 + 1;
    m.max_depth = 12;
    return m;
}

CachePoints make_caches(size_t n) {
    Rng rng(2, 0);
    CachePoints c;
    for (size_t i = 0; i < n; ++i) {
        c.position.push_back(random_point(rng));
        c.normal.push_back(random_unit(rng));
        c.origin.push_back(i % 3 == 0 ? kCacheFromCamera : kCacheFromPhoton);
    }
    return c;
}

// Maps built like fill-caches builds them: texel probabilities, then pdf = p * N / (4 pi) and the
// running sum. Cache 2 is unusable and has no map (all zeros), which the contract allows.
CacheAtlas make_atlas(size_t n, int resolution) {
    Rng rng(3, 0);
    CacheAtlas a;
    a.resolution = resolution;
    const size_t n_tex = a.texels();
    for (size_t i = 0; i < n; ++i) {
        a.position.push_back(random_point(rng));
        a.normal.push_back(random_unit(rng));
        a.photon_count.push_back(uint32_t(100 + i));
        a.radius.push_back(0.1f + rng.next_float());
        a.caustic_share.push_back(i % 4 == 0 ? 0.0f : rng.next_float());
        const bool usable = i != 2;
        a.usable.push_back(usable ? 1 : 0);
        std::vector<double> w(n_tex);
        double total = 0;
        for (size_t j = 0; j < n_tex; ++j) total += w[j] = rng.next_double() + (j % 7 == 0 ? 5.0 : 0.0);
        double running = 0;
        for (size_t j = 0; j < n_tex; ++j) {
            double p = w[j] / total;
            running += p;
            a.pdf.push_back(usable ? float(p * double(n_tex) / (4.0 * std::numbers::pi)) : 0.0f);
            a.cdf.push_back(usable ? (j + 1 == n_tex ? 1.0f : float(running)) : 0.0f);
        }
    }
    a.k = 64;
    a.filter = "gaussian";
    a.filter_sigma = 0.75;
    a.floor = 0.01;
    return a;
}

Provenance make_provenance() {
    Provenance p;
    p.tool = "trace-photons";
    p.tool_version = "0.1.0";
    p.command_line = "trace-photons scene.xml -o 'out dir/photons.h5' --seed 18446744073709551615 # \xc3\xa9t\xc3\xa9";
    p.inputs = "scene.xml 0123456789abcdef\nmeshes/bunny.obj fedcba9876543210";
    p.seed = std::numeric_limits<uint64_t>::max();  // the whole uint64 range survives
    p.parameters = {{"paths", 1e6}, {"rr_depth", 3}, {"cutoff", 1e-4}};
    return p;
}

// The message of the StageFileError that f throws, or a marker that fails every check.
template <class F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const StageFileError& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("<not a StageFileError: ") + e.what() + ">";
    }
    return "<no exception>";
}

void expect_contains(const std::string& message, const std::string& part) {
    EXPECT_NE(message.find(part), std::string::npos) << "message: " << message << "\nexpected to contain: " << part;
}

// One line that starts with the file's path.
void expect_names_file(const std::string& message, const std::string& path) {
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    expect_contains(message, fs::path(path).filename().string());
}

// ---- editing files through the HDF5 C API ----------------------------------------------------------

void edit_file(const std::string& path, const std::function<void(hid_t)>& edit) {
    hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0) << path;
    edit(f);
    ASSERT_GE(H5Fclose(f), 0);
}

void set_int_attribute(hid_t loc, const char* name, int value) {
    hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
    ASSERT_GE(a, 0) << name;
    ASSERT_GE(H5Awrite(a, H5T_NATIVE_INT, &value), 0);
    H5Aclose(a);
}

// Reads a float dataset of rank 1 or 2 as a flat array.
std::vector<float> read_floats(hid_t f, const char* name, std::vector<hsize_t>* dims) {
    hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    hid_t s = H5Dget_space(d);
    dims->assign(size_t(H5Sget_simple_extent_ndims(s)), 0);
    H5Sget_simple_extent_dims(s, dims->data(), nullptr);
    std::vector<float> v(size_t(H5Sget_simple_extent_npoints(s)));
    if (!v.empty()) H5Dread(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Sclose(s);
    H5Dclose(d);
    return v;
}

void write_floats(hid_t f, const char* name, const std::vector<float>& v) {
    hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
    H5Dclose(d);
}

// Replaces float dataset `name` by a copy without its last row.
void drop_last_row(hid_t f, const char* name) {
    std::vector<hsize_t> dims;
    std::vector<float> v = read_floats(f, name, &dims);
    ASSERT_GE(H5Ldelete(f, name, H5P_DEFAULT), 0);
    dims[0] -= 1;
    v.resize(v.size() / (dims[0] + 1) * dims[0]);
    hid_t s = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
    hid_t d = H5Dcreate2(f, name, H5T_IEEE_F32LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(d, 0);
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
    H5Dclose(d);
    H5Sclose(s);
}

std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// ---- the three kinds, for the tests every reader must pass -----------------------------------------

struct Kind {
    std::string name;    // test-name suffix
    std::string format;  // the format attribute
    std::function<void(const std::string&)> write;  // a valid file for kFingerprint
    std::function<void(const std::string&)> write_invalid;  // a refused write (NaN position)
    std::function<void(const std::string&, const std::string&)> read;         // full read (path, fingerprint)
    std::function<StageHeader(const std::string&, const std::string&)> header;  // header-only read
};

std::vector<Kind> all_kinds() {
    return {
        {"PhotonMap", kPhotonMapFormat,
         [](const std::string& p) { write_photon_map(p, make_photons(50), kFingerprint, make_provenance()); },
         [](const std::string& p) {
             PhotonMap m = make_photons(50);
             m.position[7].x = std::nanf("");
             write_photon_map(p, m, kFingerprint, make_provenance());
         },
         [](const std::string& p, const std::string& fp) { read_photon_map(p, fp); },
         [](const std::string& p, const std::string& fp) { return read_photon_map_header(p, fp); }},
        {"CachePoints", kCachePointsFormat,
         [](const std::string& p) { write_cache_points(p, make_caches(40), kFingerprint, make_provenance()); },
         [](const std::string& p) {
             CachePoints c = make_caches(40);
             c.position[3].y = std::nanf("");
             write_cache_points(p, c, kFingerprint, make_provenance());
         },
         [](const std::string& p, const std::string& fp) { read_cache_points(p, fp); },
         [](const std::string& p, const std::string& fp) { return read_cache_points_header(p, fp); }},
        {"CacheAtlas", kCacheAtlasFormat,
         [](const std::string& p) { write_cache_atlas(p, make_atlas(6, 8), kFingerprint, make_provenance()); },
         [](const std::string& p) {
             CacheAtlas a = make_atlas(6, 8);
             a.position[1].z = std::nanf("");
             write_cache_atlas(p, a, kFingerprint, make_provenance());
         },
         [](const std::string& p, const std::string& fp) { read_cache_atlas(p, fp); },
         [](const std::string& p, const std::string& fp) { return read_cache_atlas_header(p, fp); }},
    };
}

class StageFileEveryKind : public ::testing::TestWithParam<Kind> {
protected:
    TempDir dir;
    const Kind& kind() const { return GetParam(); }
    // A valid file of this kind, freshly written.
    std::string valid_file(const std::string& name = "stage.h5") {
        std::string p = dir.file(name);
        kind().write(p);
        return p;
    }
    std::string read_error(const std::string& path, const std::string& fingerprint = {}) {
        return error_of([&] { kind().read(path, fingerprint); });
    }
};

}  // namespace

// ---- refusals every reader makes -------------------------------------------------------------------

TEST_P(StageFileEveryKind, ReadsItsOwnValidFile) {
    std::string p = valid_file();
    EXPECT_NO_THROW(kind().read(p, kFingerprint));
    EXPECT_NO_THROW(kind().read(p, ""));
    StageHeader h = kind().header(p, kFingerprint);
    EXPECT_EQ(h.format, kind().format);
    EXPECT_EQ(h.format_version, 1);
    EXPECT_EQ(stage_file_format(p), kind().format);
}

TEST_P(StageFileEveryKind, RefusesMissingFile) {
    std::string p = dir.file("absent.h5");
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "cannot open");
}

TEST_P(StageFileEveryKind, RefusesNonHdf5FileWithOneQuietLine) {
    std::string p = dir.file("notes.h5");
    std::ofstream(p) << "this is not an HDF5 file\nbut a text file with a misleading name\n";
    testing::internal::CaptureStderr();
    std::string e = read_error(p);
    std::string e_header = error_of([&] { kind().header(p, ""); });
    std::string printed = testing::internal::GetCapturedStderr();
    expect_names_file(e, p);
    expect_contains(e, "not an HDF5 file");
    EXPECT_EQ(e_header, e);
    EXPECT_EQ(printed, "") << "HDF5 printed its error stack";
}

TEST_P(StageFileEveryKind, RefusesTruncatedFileWithOneQuietLine) {
    std::string p = valid_file();
    fs::resize_file(p, fs::file_size(p) / 2);
    testing::internal::CaptureStderr();
    std::string e = read_error(p);
    std::string printed = testing::internal::GetCapturedStderr();
    expect_names_file(e, p);
    expect_contains(e, "truncated");
    EXPECT_EQ(printed, "") << "HDF5 printed its error stack";
}

TEST_P(StageFileEveryKind, RefusesAnotherKindOfStageFile) {
    // The next kind in the list writes the file; this kind's reader must say what it got instead.
    std::vector<Kind> kinds = all_kinds();
    size_t me = 0;
    while (kinds[me].name != kind().name) ++me;
    const Kind& other = kinds[(me + 1) % kinds.size()];
    std::string p = dir.file("other.h5");
    other.write(p);
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "is an " + other.format + " file, expected " + kind().format);
    EXPECT_EQ(error_of([&] { kind().header(p, ""); }), e);
}

TEST_P(StageFileEveryKind, RefusesHdf5FileThatIsNoStageFile) {
    std::string p = dir.file("plain.h5");
    hid_t f = H5Fcreate(p.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    H5Fclose(f);
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "not an iris stage file");
}

TEST_P(StageFileEveryKind, RefusesUnknownVersion) {
    std::string p = valid_file();
    edit_file(p, [](hid_t f) { set_int_attribute(f, "format_version", 2); });
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "unknown format_version 2");
    EXPECT_EQ(error_of([&] { kind().header(p, ""); }), e);
}

TEST_P(StageFileEveryKind, RefusesFileMadeForAnotherScene) {
    std::string p = valid_file();
    std::string e = read_error(p, "00000000deadbeef");
    expect_names_file(e, p);
    expect_contains(e, "made for another scene (fingerprint " + kFingerprint + ", this scene is 00000000deadbeef)");
    EXPECT_EQ(error_of([&] { kind().header(p, "00000000deadbeef"); }), e);
}

TEST_P(StageFileEveryKind, RefusesMissingDataset) {
    std::string p = valid_file();
    edit_file(p, [](hid_t f) { ASSERT_GE(H5Ldelete(f, "normal", H5P_DEFAULT), 0); });
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "missing dataset 'normal'");
    // The header alone is still fine: it loads no dataset.
    EXPECT_NO_THROW(kind().header(p, kFingerprint));
}

TEST_P(StageFileEveryKind, RefusesMissingAttribute) {
    std::string p = valid_file();
    edit_file(p, [](hid_t f) { ASSERT_GE(H5Adelete(f, "scene_fingerprint"), 0); });
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "missing attribute 'scene_fingerprint'");
}

TEST_P(StageFileEveryKind, RefusesMismatchedLengths) {
    std::string p = valid_file();
    edit_file(p, [](hid_t f) { drop_last_row(f, "normal"); });
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "'normal' has");
    expect_contains(e, "'position' has");
}

TEST_P(StageFileEveryKind, RefusesNaNInPositions) {
    std::string p = valid_file();
    edit_file(p, [](hid_t f) {
        std::vector<hsize_t> dims;
        std::vector<float> v = read_floats(f, "position", &dims);
        v[3 * 1 + 1] = std::numeric_limits<float>::quiet_NaN();
        write_floats(f, "position", v);
    });
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "dataset 'position' has a non-finite value in row 1");
}

TEST_P(StageFileEveryKind, RefusesWrongShape) {
    std::string p = valid_file();
    // position as (n*3,) instead of (n, 3)
    edit_file(p, [](hid_t f) {
        std::vector<hsize_t> dims;
        std::vector<float> v = read_floats(f, "position", &dims);
        ASSERT_GE(H5Ldelete(f, "position", H5P_DEFAULT), 0);
        hsize_t flat = v.size();
        hid_t s = H5Screate_simple(1, &flat, nullptr);
        hid_t d = H5Dcreate2(f, "position", H5T_IEEE_F32LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
        H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
        H5Dclose(d);
        H5Sclose(s);
    });
    std::string e = read_error(p);
    expect_names_file(e, p);
    expect_contains(e, "dataset 'position' has shape (");
    expect_contains(e, "expected (n, 3)");
}

// ---- atomic writes ---------------------------------------------------------------------------------

TEST_P(StageFileEveryKind, WriteIntoMissingDirectoryThrowsAndLeavesNothing) {
    std::string p = dir.file("no/such/dir/out.h5");
    std::string e = error_of([&] { kind().write(p); });
    expect_names_file(e, p);
    expect_contains(e, "No such file or directory");
    EXPECT_FALSE(fs::exists(p));
    EXPECT_TRUE(dir.entries().empty());
}

TEST_P(StageFileEveryKind, SuccessfulWriteLeavesNoTemporaryFile) {
    valid_file("out.h5");
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.h5"});
    // Overwriting an existing file works the same way.
    valid_file("out.h5");
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.h5"});
}

TEST_P(StageFileEveryKind, FailedRenameRemovesTheTemporaryFile) {
    // The whole file is written, then cannot replace a directory of the same name.
    std::string p = dir.file("out.h5");
    fs::create_directory(p);
    std::string e = error_of([&] { kind().write(p); });
    expect_names_file(e, p);
    expect_contains(e, "rename");
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.h5"});
    EXPECT_TRUE(fs::is_directory(p));
}

TEST_P(StageFileEveryKind, RefusedWriteKeepsThePreviousFile) {
    std::string p = valid_file("out.h5");
    std::string before = file_bytes(p);
    std::string e = error_of([&] { kind().write_invalid(p); });
    expect_names_file(e, p);
    expect_contains(e, "refusing to write");
    expect_contains(e, "non-finite");
    EXPECT_EQ(file_bytes(p), before);
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.h5"});
}

TEST_P(StageFileEveryKind, H5dumpReadsTheFile) {
    if (std::system("command -v h5dump >/dev/null 2>&1") != 0) GTEST_SKIP() << "h5dump is not on PATH";
    std::string p = valid_file();
    int header = std::system(("h5dump -H '" + p + "' >/dev/null 2>&1").c_str());
    ASSERT_NE(header, -1);
    EXPECT_TRUE(WIFEXITED(header) && WEXITSTATUS(header) == 0) << "h5dump -H exited with " << header;
    int full = std::system(("h5dump '" + p + "' >/dev/null 2>&1").c_str());
    EXPECT_TRUE(WIFEXITED(full) && WEXITSTATUS(full) == 0) << "h5dump exited with " << full;
}

INSTANTIATE_TEST_SUITE_P(Stage, StageFileEveryKind, ::testing::ValuesIn(all_kinds()),
                         [](const ::testing::TestParamInfo<Kind>& info) { return info.param.name; });

// ---- common attributes -----------------------------------------------------------------------------

TEST(StageFileCommon, ProvenanceRoundTrips) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    write_photon_map(p, make_photons(5), kFingerprint, make_provenance());
    StageHeader h = read_photon_map_header(p, kFingerprint);
    Provenance want = make_provenance();
    EXPECT_EQ(h.format, "iris-photon-map");
    EXPECT_EQ(h.format_version, 1);
    EXPECT_EQ(h.scene_fingerprint, kFingerprint);
    EXPECT_EQ(h.provenance.tool, want.tool);
    EXPECT_EQ(h.provenance.tool_version, want.tool_version);
    EXPECT_EQ(h.provenance.command_line, want.command_line);
    EXPECT_EQ(h.provenance.inputs, want.inputs);
    EXPECT_EQ(h.provenance.seed, want.seed);
    EXPECT_EQ(h.provenance.parameters, want.parameters);
    EXPECT_TRUE(std::regex_match(h.created, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)"))) << h.created;
    // The full read returns the same header.
    PhotonMapFile f = read_photon_map(p, kFingerprint);
    EXPECT_EQ(f.header.provenance.command_line, want.command_line);
    EXPECT_EQ(f.header.created, h.created);
}

TEST(StageFileCommon, WriterRefusesMissingFingerprintOrTool) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    expect_contains(error_of([&] { write_photon_map(p, make_photons(3), "", make_provenance()); }),
                    "no scene fingerprint");
    Provenance anonymous = make_provenance();
    anonymous.tool.clear();
    expect_contains(error_of([&] { write_photon_map(p, make_photons(3), kFingerprint, anonymous); }), "no tool name");
    Provenance nan_parameter = make_provenance();
    nan_parameter.parameters["k"] = std::nan("");
    expect_contains(error_of([&] { write_photon_map(p, make_photons(3), kFingerprint, nan_parameter); }),
                    "parameter 'k' is not finite");
    EXPECT_TRUE(dir.entries().empty());
}

TEST(StageFileCommon, SameInputsGiveIdenticalBytes) {
    // With the clock pinned, nothing else in the file depends on when or where it was written
    // (no object timestamps): golden files can be compared byte for byte.
    TempDir dir;
    const char* old = std::getenv("SOURCE_DATE_EPOCH");
    std::string saved = old ? old : "";
    setenv("SOURCE_DATE_EPOCH", "1700000000", 1);
    write_cache_atlas(dir.file("a.h5"), make_atlas(30, 16), kFingerprint, make_provenance());
    write_cache_atlas(dir.file("b.h5"), make_atlas(30, 16), kFingerprint, make_provenance());
    if (old)
        setenv("SOURCE_DATE_EPOCH", saved.c_str(), 1);
    else
        unsetenv("SOURCE_DATE_EPOCH");
    EXPECT_EQ(read_cache_atlas_header(dir.file("a.h5")).created, "2023-11-14T22:13:20Z");
    EXPECT_TRUE(file_bytes(dir.file("a.h5")) == file_bytes(dir.file("b.h5")));
}

TEST(StageFileCommon, RestoresHdf5ErrorPrinting) {
    // The readers silence HDF5's own error printing only while they run.
    H5E_auto2_t before_func = nullptr;
    void* before_data = nullptr;
    H5Eget_auto2(H5E_DEFAULT, &before_func, &before_data);
    TempDir dir;
    std::string p = dir.file("x.h5");
    std::ofstream(p) << "garbage";
    EXPECT_NE(error_of([&] { read_cache_points(p); }), "<no exception>");
    H5E_auto2_t after_func = nullptr;
    void* after_data = nullptr;
    H5Eget_auto2(H5E_DEFAULT, &after_func, &after_data);
    EXPECT_EQ(after_func, before_func);
    EXPECT_EQ(after_data, before_data);
}

TEST(StageFileCommon, FileFingerprintIsFnv1a64OfTheBytes) {
    TempDir dir;
    std::ofstream(dir.file("empty")).close();
    std::ofstream(dir.file("a")) << "a";
    EXPECT_EQ(file_fingerprint(dir.file("empty")), "cbf29ce484222325");
    EXPECT_EQ(file_fingerprint(dir.file("a")), "af63dc4c8601ec8c");
    expect_names_file(error_of([&] { file_fingerprint(dir.file("absent")); }), dir.file("absent"));
}

// ---- photons.h5 ------------------------------------------------------------------------------------

TEST(StageFilePhotonMap, RoundTripsEveryValue) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    PhotonMap m = make_photons(123);
    write_photon_map(p, m, kFingerprint, make_provenance());
    PhotonMap r = read_photon_map(p, kFingerprint).photons;
    ASSERT_EQ(r.size(), m.size());
    EXPECT_EQ(r.emitted_paths, m.emitted_paths);
    EXPECT_EQ(r.max_depth, m.max_depth);
    EXPECT_EQ(r.bounces, m.bounces);
    EXPECT_EQ(r.caustic, m.caustic);
    for (size_t i = 0; i < m.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            // float32 in, float32 out: exact.
            EXPECT_EQ(r.position[i][c], m.position[i][c]);
            EXPECT_EQ(r.direction[i][c], m.direction[i][c]);
            EXPECT_EQ(r.normal[i][c], m.normal[i][c]);
            EXPECT_EQ(r.power[i][c], m.power[i][c]);
        }
}

TEST(StageFilePhotonMap, EmptyMapRoundTrips) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    PhotonMap m;  // a scene whose lights reach nothing
    m.emitted_paths = 1000;
    write_photon_map(p, m, kFingerprint, make_provenance());
    PhotonMap r = read_photon_map(p).photons;
    EXPECT_EQ(r.size(), 0u);
    EXPECT_EQ(r.emitted_paths, 1000u);
    EXPECT_EQ(r.max_depth, -1);
}

TEST(StageFilePhotonMap, LargeDatasetsAreChunkedAndCompressed) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    PhotonMap m = make_photons(20000);
    write_photon_map(p, m, kFingerprint, make_provenance());
    hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    for (const char* name : {"position", "direction", "power", "normal"}) {
        hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
        hid_t dcpl = H5Dget_create_plist(d);
        EXPECT_EQ(H5Pget_layout(dcpl), H5D_CHUNKED) << name;
        EXPECT_EQ(H5Pget_nfilters(dcpl), 2) << name << ": shuffle + deflate";
        H5Pclose(dcpl);
        H5Dclose(d);
    }
    H5Fclose(f);
    PhotonMap r = read_photon_map(p).photons;
    ASSERT_EQ(r.size(), m.size());
    EXPECT_EQ(r.position.back().x, m.position.back().x);
    EXPECT_EQ(r.power[12345].g, m.power[12345].g);
}

// Large datasets are deflated in parallel by iris itself and stored with H5Dwrite_chunk, and read back
// with H5Dread_chunk. Both directions must agree with HDF5's own shuffle + deflate filters.
TEST(StageFilePhotonMap, ParallelCodecAgreesWithHdf5Filters) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    PhotonMap m = make_photons(50000);  // 600 kB per dataset: 3 chunks, the last one partial
    write_photon_map(p, m, kFingerprint, make_provenance());
    // iris -> HDF5: the library's own filter pipeline decodes what iris encoded.
    hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    std::vector<hsize_t> dims;
    std::vector<float> position = read_floats(f, "position", &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{50000, 3}));
    for (size_t i = 0; i < m.size(); ++i)
        for (int c = 0; c < 3; ++c) ASSERT_EQ(position[3 * i + c], m.position[i][c]) << "row " << i;
    // HDF5 -> iris: replace 'power' by a dataset HDF5 itself filtered (other chunk size and level).
    std::vector<float> power(3 * m.size());
    for (size_t i = 0; i < m.size(); ++i)
        for (int c = 0; c < 3; ++c) power[3 * i + c] = m.power[i][c] * 2.0f;
    ASSERT_GE(H5Ldelete(f, "power", H5P_DEFAULT), 0);
    hsize_t shape[2] = {m.size(), 3}, chunk[2] = {7000, 3};
    hid_t s = H5Screate_simple(2, shape, nullptr);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 2, chunk);
    H5Pset_shuffle(dcpl);
    H5Pset_deflate(dcpl, 6);
    hid_t d = H5Dcreate2(f, "power", H5T_IEEE_F32LE, s, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, power.data()), 0);
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(s);
    H5Fclose(f);
    PhotonMap r = read_photon_map(p).photons;
    ASSERT_EQ(r.size(), m.size());
    for (size_t i = 0; i < m.size(); ++i) {
        ASSERT_EQ(r.power[i].r, power[3 * i]) << "row " << i;
        ASSERT_EQ(r.position[i].z, m.position[i].z) << "row " << i;
    }
}

TEST(StageFilePhotonMap, RefusesNormalFacingAwayFromTheIncidentSide) {
    PhotonMap m = make_photons(10);
    m.normal[4] = -m.normal[4];
    expect_contains(validate_photon_map(m), "photon 4: 'normal' faces away from 'direction'");
    TempDir dir;
    std::string p = dir.file("photons.h5");
    expect_names_file(error_of([&] { write_photon_map(p, m, kFingerprint, make_provenance()); }), p);
    EXPECT_FALSE(fs::exists(p));
}

TEST(StageFilePhotonMap, RefusesNegativePowerAndMissingPathCount) {
    PhotonMap m = make_photons(10);
    m.power[2].b = -1e-6f;
    expect_contains(validate_photon_map(m), "'power' has a negative value in row 2");
    m = make_photons(10);
    m.emitted_paths = 0;
    expect_contains(validate_photon_map(m), "'emitted_paths' is 0");
    m = make_photons(10);
    m.direction[9] = Vec3(0.5f, 0, 0);
    expect_contains(validate_photon_map(m), "'direction' row 9 is not a unit vector");
}

TEST(StageFilePhotonMap, RefusesCountThatDisagreesWithTheData) {
    TempDir dir;
    std::string p = dir.file("photons.h5");
    write_photon_map(p, make_photons(10), kFingerprint, make_provenance());
    edit_file(p, [](hid_t f) {
        hid_t a = H5Aopen(f, "photon_count", H5P_DEFAULT);
        uint64_t v = 11;
        H5Awrite(a, H5T_NATIVE_UINT64, &v);
        H5Aclose(a);
    });
    std::string e = error_of([&] { read_photon_map(p); });
    expect_names_file(e, p);
    expect_contains(e, "'photon_count' is 11");
}

// ---- caches.h5 -------------------------------------------------------------------------------------

TEST(StageFileCachePoints, RoundTripsEveryValue) {
    TempDir dir;
    std::string p = dir.file("caches.h5");
    CachePoints c = make_caches(77);
    Provenance prov = make_provenance();
    prov.tool = "place-caches";
    prov.parameters = {{"camera_stride", 8}, {"count", 20000}};
    write_cache_points(p, c, kFingerprint, prov);
    CachePointsFile f = read_cache_points(p, kFingerprint);
    EXPECT_EQ(f.header.provenance.parameters, prov.parameters);
    EXPECT_EQ(f.header.provenance.tool, "place-caches");
    const CachePoints& r = f.caches;
    ASSERT_EQ(r.size(), c.size());
    for (size_t i = 0; i < c.size(); ++i) {
        EXPECT_EQ(r.origin[i], c.origin[i]);
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(r.position[i][k], c.position[i][k]);
            EXPECT_EQ(r.normal[i][k], c.normal[i][k]);
        }
    }
}

TEST(StageFileCachePoints, RefusesUnknownOrigin) {
    TempDir dir;
    std::string p = dir.file("caches.h5");
    write_cache_points(p, make_caches(5), kFingerprint, make_provenance());
    edit_file(p, [](hid_t f) {
        hid_t d = H5Dopen2(f, "origin", H5P_DEFAULT);
        std::vector<uint8_t> v = {0, 1, 7, 1, 0};
        H5Dwrite(d, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
        H5Dclose(d);
    });
    std::string e = error_of([&] { read_cache_points(p); });
    expect_names_file(e, p);
    expect_contains(e, "dataset 'origin' has the value 7 in row 2");
}

// ---- atlas.h5 --------------------------------------------------------------------------------------

TEST(StageFileCacheAtlas, RoundTripsEveryValue) {
    TempDir dir;
    std::string p = dir.file("atlas.h5");
    CacheAtlas a = make_atlas(600, 16);  // 600 kB per map dataset: chunked, 3 chunks, the last partial
    Provenance prov = make_provenance();
    prov.tool = "fill-caches";
    prov.parameters = {{"k", 64}, {"min_photons", 16}};
    write_cache_atlas(p, a, kFingerprint, prov);
    CacheAtlasFile f = read_cache_atlas(p, kFingerprint);
    EXPECT_EQ(f.header.provenance.parameters, prov.parameters);
    const CacheAtlas& r = f.atlas;
    EXPECT_EQ(r.resolution, 16);
    EXPECT_EQ(r.k, 64);
    EXPECT_EQ(r.filter, "gaussian");
    EXPECT_EQ(r.filter_sigma, 0.75);
    EXPECT_EQ(r.floor, 0.01);
    ASSERT_EQ(r.size(), a.size());
    EXPECT_EQ(r.pdf, a.pdf);
    EXPECT_EQ(r.cdf, a.cdf);
    EXPECT_EQ(r.photon_count, a.photon_count);
    EXPECT_EQ(r.radius, a.radius);
    EXPECT_EQ(r.usable, a.usable);
    EXPECT_EQ(r.caustic_share, a.caustic_share);
    for (size_t i = 0; i < a.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(r.position[i][k], a.position[i][k]);
            EXPECT_EQ(r.normal[i][k], a.normal[i][k]);
        }
    // The texel solid angle is 4 pi / N exactly: each usable row integrates to one.
    double sum = 0;
    for (size_t j = 0; j < r.texels(); ++j) sum += r.pdf_row(0)[j] * 4.0 * std::numbers::pi / double(r.texels());
    EXPECT_NEAR(sum, 1.0, 1e-5);
    // The mapping is recorded for readers that do not use iris; the maps are compressed.
    hid_t fh = H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    EXPECT_GT(H5Aexists(fh, "mapping"), 0);
    hid_t d = H5Dopen2(fh, "pdf", H5P_DEFAULT);
    hid_t dcpl = H5Dget_create_plist(d);
    EXPECT_EQ(H5Pget_layout(dcpl), H5D_CHUNKED);
    EXPECT_EQ(H5Pget_nfilters(dcpl), 2);
    H5Pclose(dcpl);
    H5Dclose(d);
    H5Fclose(fh);
}

TEST(StageFileOptionalFlags, AbsentWhenNotWrittenAndRefusedOutOfRange) {
    TempDir dir;
    // Written without the optional datasets, read back without them (older files stay valid).
    PhotonMap m = make_photons(20);
    m.bounces.clear();
    m.caustic.clear();
    write_photon_map(dir.file("plain.h5"), m, kFingerprint, make_provenance());
    PhotonMap r = read_photon_map(dir.file("plain.h5"), kFingerprint).photons;
    EXPECT_TRUE(r.bounces.empty());
    EXPECT_TRUE(r.caustic.empty());
    // A flag other than 0/1, a share outside [0, 1], and a wrong row count are refused by the writer.
    m = make_photons(20);
    m.caustic[7] = 2;
    expect_contains(error_of([&] { write_photon_map(dir.file("bad.h5"), m, kFingerprint, make_provenance()); }),
                    "dataset 'caustic' has the value 2 in row 7");
    m.caustic.pop_back();
    expect_contains(error_of([&] { write_photon_map(dir.file("bad.h5"), m, kFingerprint, make_provenance()); }),
                    "caustic");
    CacheAtlas a = make_atlas(6, 8);
    a.caustic_share[3] = 1.5f;
    expect_contains(error_of([&] { write_cache_atlas(dir.file("bad.h5"), a, kFingerprint, make_provenance()); }),
                    "dataset 'caustic_share' is 1.5");
    a.caustic_share[3] = std::nanf("");
    expect_contains(error_of([&] { write_cache_atlas(dir.file("bad.h5"), a, kFingerprint, make_provenance()); }),
                    "caustic_share");
    EXPECT_FALSE(std::filesystem::exists(dir.file("bad.h5")));
}

TEST(StageFileCacheAtlas, RefusesCdfNotEndingAtOne) {
    TempDir dir;
    std::string p = dir.file("atlas.h5");
    write_cache_atlas(p, make_atlas(4, 8), kFingerprint, make_provenance());
    // Scale row 1 of both maps: the cdf still matches its pdf, but the distribution sums to 0.99.
    edit_file(p, [](hid_t f) {
        for (const char* name : {"pdf", "cdf"}) {
            std::vector<hsize_t> dims;
            std::vector<float> v = read_floats(f, name, &dims);
            for (size_t j = 0; j < dims[1]; ++j) v[dims[1] + j] *= 0.99f;
            write_floats(f, name, v);
        }
    });
    std::string e = error_of([&] { read_cache_atlas(p); });
    expect_names_file(e, p);
    expect_contains(e, "dataset 'cdf' of cache 1 ends at 0.99");
}

// The renderer's read (AtlasMaps::PdfOnly) loads everything but the cdf, which it never uses, and then
// checks that each pdf row itself sums to one.
TEST(StageFileCacheAtlas, PdfOnlyReadSkipsTheCdfAndChecksThePdfSums) {
    TempDir dir;
    std::string p = dir.file("atlas.h5");
    CacheAtlas a = make_atlas(5, 8);
    write_cache_atlas(p, a, kFingerprint, make_provenance());
    CacheAtlas r = read_cache_atlas(p, kFingerprint, AtlasMaps::PdfOnly).atlas;
    EXPECT_TRUE(r.cdf.empty());
    EXPECT_EQ(r.pdf, a.pdf);
    EXPECT_EQ(r.usable, a.usable);
    EXPECT_EQ(r.radius, a.radius);
    // A cdf the renderer does not read cannot stop it; the full read still refuses it.
    edit_file(p, [](hid_t f) {
        std::vector<hsize_t> dims;
        std::vector<float> v = read_floats(f, "cdf", &dims);
        v[dims[1] + 3] = -1;
        write_floats(f, "cdf", v);
    });
    EXPECT_EQ(read_cache_atlas(p, kFingerprint, AtlasMaps::PdfOnly).atlas.pdf, a.pdf);
    expect_contains(error_of([&] { read_cache_atlas(p, kFingerprint); }), "dataset 'cdf' decreases at cache 1");
    // A pdf row that sums to 0.99 is refused (by the full read too, through the cdf check).
    edit_file(p, [](hid_t f) {
        std::vector<hsize_t> dims;
        std::vector<float> v = read_floats(f, "pdf", &dims);
        for (size_t j = 0; j < dims[1]; ++j) v[3 * dims[1] + j] *= 0.99f;
        write_floats(f, "pdf", v);
    });
    std::string e = error_of([&] { read_cache_atlas(p, kFingerprint, AtlasMaps::PdfOnly); });
    expect_names_file(e, p);
    expect_contains(e, "dataset 'pdf' of cache 3 sums to 0.99");
    // Without PdfOnly an empty cdf is a wrong shape.
    CacheAtlas no_cdf = a;
    no_cdf.cdf.clear();
    expect_contains(validate_cache_atlas(no_cdf), "dataset 'cdf' has 0 values");
    EXPECT_EQ(validate_cache_atlas(no_cdf, AtlasMaps::PdfOnly), "");
}

TEST(StageFileCacheAtlas, RefusesBrokenMaps) {
    CacheAtlas good = make_atlas(4, 8);
    EXPECT_EQ(validate_cache_atlas(good), "");

    CacheAtlas a = good;
    a.cdf[a.texels() + 11] = a.cdf[a.texels() + 10] - 1e-5f;
    expect_contains(validate_cache_atlas(a), "dataset 'cdf' decreases at cache 1, texel 11");

    a = good;
    a.pdf[5] = -a.pdf[5];
    expect_contains(validate_cache_atlas(a), "dataset 'pdf' has a negative value at cache 0, texel 5");

    a = good;
    a.pdf[3 * a.texels() + 1] = std::numeric_limits<float>::infinity();
    expect_contains(validate_cache_atlas(a), "dataset 'pdf' has a non-finite value at cache 3, texel 1");

    a = good;
    a.pdf[7] *= 2;  // the cdf no longer describes the pdf
    expect_contains(validate_cache_atlas(a), "not the running sum of pdf * 4*pi/N at cache 0, texel 7");

    a = good;
    a.usable[2] = 1;  // cache 2 has no map
    expect_contains(validate_cache_atlas(a), "cache 2 is usable but its pdf and cdf are all zero");

    a = good;
    a.pdf.pop_back();
    expect_contains(validate_cache_atlas(a), "dataset 'pdf' has 255 values, expected 4 caches x 64 texels");
}

TEST(StageFileCacheAtlas, RefusesResolutionThatDoesNotMatchTheMaps) {
    TempDir dir;
    std::string p = dir.file("atlas.h5");
    write_cache_atlas(p, make_atlas(4, 8), kFingerprint, make_provenance());
    edit_file(p, [](hid_t f) { set_int_attribute(f, "resolution", 4); });
    std::string e = error_of([&] { read_cache_atlas(p); });
    expect_names_file(e, p);
    expect_contains(e, "dataset 'pdf' has shape (4, 64), expected (n, 16)");
}

// The renderer packs maps up to 256 x 256 (libguide/packed_map.h): a larger one is refused on reading,
// naming the file, rather than failing later inside the guide.
TEST(StageFileCacheAtlas, RefusesResolutionAboveWhatTheRendererPacks) {
    TempDir dir;
    std::string p = dir.file("atlas.h5");
    write_cache_atlas(p, make_atlas(2, 4), kFingerprint, make_provenance());
    edit_file(p, [](hid_t f) { set_int_attribute(f, "resolution", kCacheAtlasMaxResolution + 1); });
    std::string e = error_of([&] { read_cache_atlas(p); });
    expect_names_file(e, p);
    expect_contains(e, "attribute 'resolution' is 257 (must be 1..256)");
}

TEST(StageFileCacheAtlas, RefusesUnknownMapping) {
    TempDir dir;
    std::string p = dir.file("atlas.h5");
    write_cache_atlas(p, make_atlas(2, 4), kFingerprint, make_provenance());
    edit_file(p, [](hid_t f) {
        ASSERT_GE(H5Adelete(f, "mapping"), 0);
        hid_t t = H5Tcopy(H5T_C_S1);
        H5Tset_size(t, 8);  // fixed-length, as some writers make them: also readable
        hid_t s = H5Screate(H5S_SCALAR);
        hid_t a = H5Acreate2(f, "mapping", t, s, H5P_DEFAULT, H5P_DEFAULT);
        H5Awrite(a, t, "latlong\0");
        H5Aclose(a);
        H5Sclose(s);
        H5Tclose(t);
    });
    std::string e = error_of([&] { read_cache_atlas(p); });
    expect_names_file(e, p);
    expect_contains(e, "unknown mapping 'latlong'");
}
