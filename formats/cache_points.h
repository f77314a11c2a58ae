// caches.h5, the output of place-caches: where the radiance caches go and which side of the surface
// each one serves. Layout, units and conventions: formats/README.md, "iris-cache-points".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "formats/hdf5_util.h"
#include "libcommon/math.h"

namespace iris {

inline constexpr const char* kCachePointsFormat = "iris-cache-points";
inline constexpr int kCachePointsVersion = 1;

// Values of CachePoints::origin. (Plain constants, not an enum: place-caches has its own enum with the
// same values, and the file stores a plain uint8.)
inline constexpr uint8_t kCacheFromCamera = 0;  // placed where a camera ray (or its specular chain) landed
inline constexpr uint8_t kCacheFromPhoton = 1;  // placed at a photon's position

// Cache points as parallel arrays, all of size().
struct CachePoints {
    std::vector<Vec3> position;  // world units
    std::vector<Vec3> normal;    // unit; points into the side of the surface the cache serves
    std::vector<uint8_t> origin; // kCacheFromCamera or kCacheFromPhoton

    size_t size() const { return position.size(); }
};

struct CachePointsFile {
    StageHeader header;
    CachePoints caches;
};

// "" if `caches` satisfies the contract, else what is wrong (naming the dataset and row).
std::string validate_cache_points(const CachePoints& caches);

// Writes atomically. Stage parameters (camera_stride, count, ...) go in provenance.parameters.
void write_cache_points(const std::string& path, const CachePoints& caches, const std::string& scene_fingerprint,
                        const Provenance& provenance);

// Reads and validates the whole file; expected_fingerprint "" skips the scene check.
CachePointsFile read_cache_points(const std::string& path, const std::string& expected_fingerprint = {});

// Only the root attributes: no cache is loaded.
StageHeader read_cache_points_header(const std::string& path, const std::string& expected_fingerprint = {});

}  // namespace iris
