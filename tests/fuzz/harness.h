// Fuzzing harness: one function per target that feeds arbitrary bytes to a real iris reader and
// swallows only the error type that reader documents. Any other exception escapes on purpose: under
// libFuzzer (tests/fuzz/fuzz_*.cpp) it aborts the run and is reported as a finding, and in the
// regression test (tests/unit/test_fuzz_regressions.cpp) it fails the test.
//
// Header-only and compiler-neutral (no libFuzzer or sanitizer API), so the g++ Release build runs the
// saved crash inputs through exactly the same code as the fuzzers.
//
//   scene_xml_one   bytes = a scene XML file      -> load_scene       (SceneError)
//   obj_one         bytes = OBJ text              -> parse_obj        (ObjError)
//   mesh_one        bytes = a PLY file ("ply" first) -> parse_ply, or a Mitsuba serialized file
//                   -> serialized_shape_count and parse_serialized of shapes 0 and 1 (MeshFileError)
//   stage_hdf5_one  byte 0 picks the reader, the rest is the HDF5 file
//                   -> read_photon_map / read_cache_points / read_cache_atlas, their _header
//                      variants, read_stage_header, stage_file_format  (StageFileError)
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/hdf5_util.h"
#include "formats/obj.h"
#include "formats/photon_map.h"
#include "formats/ply.h"
#include "formats/serialized.h"
#include "formats/scene_xml.h"

namespace iris::fuzz {

// Files every scene input may refer to by these relative names (the fuzzer's dictionary and the seed
// corpus use them): two small valid meshes and a scene fragment for <include>.
inline constexpr const char* kSceneFile = "scene.xml";
inline constexpr const char* kMeshQuad = "mesh.obj";  // a unit quad without normals
inline constexpr const char* kMeshTri = "tri.obj";    // a triangle with per-corner normals
inline constexpr const char* kIncludeFile = "include.xml";
inline constexpr const char* kStageFile = "stage.h5";

namespace detail {

inline void write_file(const std::filesystem::path& path, const void* data, size_t size) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(data), std::streamsize(size));
    out.close();
    // A harness that cannot write its input would fuzz nothing: fail loudly, not silently.
    if (!out) {
        std::fprintf(stderr, "iris fuzz harness: cannot write %s\n", path.c_str());
        std::abort();
    }
}

inline void write_text(const std::filesystem::path& path, std::string_view text) {
    write_file(path, text.data(), text.size());
}

// Removes the scratch folders of harness processes that are gone (a crashing fuzzer, and every job of
// libFuzzer's fork mode, ends with _Exit and leaves its folder behind).
inline void remove_stale_scratch_dirs(const std::filesystem::path& parent) {
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(parent, ec)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("iris-fuzz-", 0) != 0) continue;
        const std::string pid = name.substr(10, name.find('-', 10) - 10);
        if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) continue;
        if (!std::filesystem::exists("/proc/" + pid, ec)) std::filesystem::remove_all(e.path(), ec);
    }
}

inline std::filesystem::path make_scratch_dir() {
    // /dev/shm keeps the per-input file writes off the disk; /tmp where it does not exist.
    const std::filesystem::path parent = std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp";
    remove_stale_scratch_dirs(parent);
    std::string templ = (parent / ("iris-fuzz-" + std::to_string(::getpid()) + "-XXXXXX")).string();
    if (!::mkdtemp(templ.data())) {
        std::perror("iris fuzz harness: mkdtemp");
        std::abort();
    }
    std::filesystem::path dir = templ;
    write_text(dir / kMeshQuad,
               "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
               "f 1 2 3 4\n");
    write_text(dir / kMeshTri,
               "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
               "vn 0 0 1\nvn 0 0.5 1\nvn 0.5 0 1\n"
               "f 1//1 2//2 3//3\n");
    write_text(dir / kIncludeFile,
               "<scene version=\"0.5.0\">\n"
               "  <bsdf type=\"diffuse\" id=\"included\"><rgb name=\"reflectance\" value=\"0.2 0.4 0.6\"/></bsdf>\n"
               "</scene>\n");
    return dir;
}

}  // namespace detail

// The per-process scratch directory /dev/shm/iris-fuzz-PID-XXXXXX (created on first use, removed at
// normal exit, and by the next harness process if this one crashes).
inline const std::filesystem::path& scratch_dir() {
    static const std::filesystem::path dir = [] {
        std::filesystem::path d = detail::make_scratch_dir();
        static std::filesystem::path to_remove;
        to_remove = d;
        std::atexit([] {
            std::error_code ec;
            std::filesystem::remove_all(to_remove, ec);
        });
        return d;
    }();
    return dir;
}

// Scene XML. load_scene = parse_scene + Scene::finalize (BSDF preparation, light set-up, Embree BVH):
// the BVH build costs little on the tiny scenes a fuzzer makes, and finalize sees the same data a
// tool would. Warnings are collected instead of printed.
inline int scene_xml_one(const uint8_t* data, size_t size) {
    const std::filesystem::path path = scratch_dir() / kSceneFile;
    detail::write_file(path, data, size);
    SceneLoadOptions options;
    std::vector<std::string> warnings;
    options.warnings = &warnings;
    try {
        Scene scene = load_scene(path.string(), options);
    } catch (const SceneError&) {
    }
    return 0;
}

// OBJ text, straight from memory (the name only prefixes messages).
inline int obj_one(const uint8_t* data, size_t size) {
    try {
        ObjMesh mesh = parse_obj(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.obj");
    } catch (const ObjError&) {
    }
    return 0;
}

// PLY or Mitsuba serialized mesh bytes, straight from memory.
inline int mesh_one(const uint8_t* data, size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    try {
        if (bytes.substr(0, 3) == "ply") {
            TriangleMesh m = parse_ply(bytes, "fuzz.ply");
        } else {
            serialized_shape_count(bytes, "fuzz.serialized");
            for (uint32_t i = 0; i < 2; ++i) TriangleMesh m = parse_serialized(bytes, i, "fuzz.serialized");
        }
    } catch (const MeshFileError&) {
    }
    return 0;
}

// HDF5 stage files. Byte 0 chooses the reader (so one corpus file can be tried against every reader
// by changing one byte), the remaining bytes are the file. The readers switch HDF5's automatic
// error printing off themselves (formats/hdf5_util.cpp, QuietHdf5): the harness does not, so a
// reader that forgot to would show up as HDF5-DIAG noise in the fuzzer's output.
inline int stage_hdf5_one(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    const std::filesystem::path path = scratch_dir() / kStageFile;
    detail::write_file(path, data + 1, size - 1);
    const std::string p = path.string();
    try {
        switch (data[0] % 8) {
            case 0: read_photon_map(p); break;
            case 1: read_photon_map_header(p); break;
            case 2: read_cache_points(p); break;
            case 3: read_cache_points_header(p); break;
            case 4: read_cache_atlas(p); break;
            case 5: read_cache_atlas_header(p); break;
            // Any kind and version 1: whatever format attribute the file claims is checked against.
            case 6: read_stage_header(p, {}, 1); break;
            case 7: stage_file_format(p); break;
        }
    } catch (const StageFileError&) {
    }
    return 0;
}

}  // namespace iris::fuzz
