#include "formats/cache_points.h"

namespace iris {

std::string validate_cache_points(const CachePoints& c) {
    const size_t n = c.size();
    if (std::string e = h5::check_rows("normal", c.normal.size(), "position", n); !e.empty()) return e;
    if (std::string e = h5::check_rows("origin", c.origin.size(), "position", n); !e.empty()) return e;
    if (std::string e = h5::check_finite("position", c.position); !e.empty()) return e;
    if (std::string e = h5::check_unit("normal", c.normal); !e.empty()) return e;
    for (size_t i = 0; i < n; ++i)
        if (c.origin[i] != kCacheFromCamera && c.origin[i] != kCacheFromPhoton)
            return "dataset 'origin' has the value " + std::to_string(c.origin[i]) + " in row " + std::to_string(i) +
                   " (0 = camera, 1 = photon)";
    return {};
}

void write_cache_points(const std::string& path, const CachePoints& caches, const std::string& scene_fingerprint,
                        const Provenance& provenance) {
    if (std::string e = validate_cache_points(caches); !e.empty())
        throw StageFileError(path + ": refusing to write: " + e);
    h5::Writer w(path, kCachePointsFormat, kCachePointsVersion, scene_fingerprint, provenance);
    w.attribute_u64("cache_count", caches.size());
    w.dataset("position", caches.position, "world units", "cache position, on a surface");
    w.dataset("normal", caches.normal, "unit vector", "surface normal on the side the cache serves");
    w.dataset("origin", caches.origin, "enum", "what placed the cache: 0 = camera ray, 1 = photon");
    w.commit();
}

CachePointsFile read_cache_points(const std::string& path, const std::string& expected_fingerprint) {
    h5::Reader r(path, kCachePointsFormat, kCachePointsVersion, expected_fingerprint);
    CachePointsFile f;
    f.header = r.header();
    CachePoints& c = f.caches;
    const uint64_t count = r.attribute_uint("cache_count");
    c.position = r.vec3s("position");
    c.normal = r.vec3s("normal");
    c.origin = r.u8s("origin");
    if (count != c.size())
        r.fail("attribute 'cache_count' is " + std::to_string(count) + " but dataset 'position' has " +
               std::to_string(c.size()) + " rows");
    if (std::string e = validate_cache_points(c); !e.empty()) r.fail(e);
    return f;
}

StageHeader read_cache_points_header(const std::string& path, const std::string& expected_fingerprint) {
    return read_stage_header(path, kCachePointsFormat, kCachePointsVersion, expected_fingerprint);
}

}  // namespace iris
