#include "formats/cache_atlas.h"

#include <cmath>
#include <cstdint>
#include <numbers>

namespace iris {

namespace {

// Checks row `i` of the maps (of the pdf alone where the atlas was read without its cdf). Sums run in
// double so that the tolerances measure the file's rounding, not this check's.
std::string check_map_row(const CacheAtlas& a, size_t i) {
    const size_t n_tex = a.texels();
    const bool has_cdf = !a.cdf.empty();
    const float* pdf = a.pdf_row(i);
    const float* cdf = has_cdf ? a.cdf_row(i) : nullptr;
    const std::string where = " at cache " + std::to_string(i) + ", texel ";
    bool all_zero = true;
    for (size_t j = 0; j < n_tex; ++j) {
        if (!std::isfinite(pdf[j])) return "dataset 'pdf' has a non-finite value" + where + std::to_string(j);
        if (pdf[j] < 0) return "dataset 'pdf' has a negative value" + where + std::to_string(j);
        if (has_cdf && !std::isfinite(cdf[j])) return "dataset 'cdf' has a non-finite value" + where + std::to_string(j);
        all_zero = all_zero && pdf[j] == 0 && (!has_cdf || cdf[j] == 0);
    }
    // An unusable cache may carry no map at all; the renderer never samples it.
    if (all_zero) {
        if (a.usable[i]) return "cache " + std::to_string(i) + " is usable but its pdf and cdf are all zero";
        return {};
    }
    const double texel_sr = 4.0 * std::numbers::pi / double(n_tex);  // solid angle of every texel, sr
    if (!has_cdf) {
        double sum = 0;
        for (size_t j = 0; j < n_tex; ++j) sum += double(pdf[j]) * texel_sr;
        // What the cdf checks imply for a row's sum: within 1e-3 of the running sum, which ends within 1e-4 of 1.
        if (std::abs(sum - 1.0) > 1.1e-3)
            return "dataset 'pdf' of cache " + std::to_string(i) + " sums to " + std::to_string(sum) +
                   " (times 4*pi/N), not 1";
        return {};
    }
    double running = 0, previous = 0;
    for (size_t j = 0; j < n_tex; ++j) {
        if (cdf[j] < previous)
            return "dataset 'cdf' decreases" + where + std::to_string(j) + " (" + std::to_string(previous) + " -> " +
                   std::to_string(cdf[j]) + ")";
        previous = cdf[j];
        running += double(pdf[j]) * texel_sr;
        if (std::abs(cdf[j] - running) > 1e-3)
            return "dataset 'cdf' is not the running sum of pdf * 4*pi/N" + where + std::to_string(j) + " (cdf " +
                   std::to_string(cdf[j]) + ", sum " + std::to_string(running) + ")";
    }
    if (std::abs(double(cdf[n_tex - 1]) - 1.0) > 1e-4)
        return "dataset 'cdf' of cache " + std::to_string(i) + " ends at " + std::to_string(cdf[n_tex - 1]) +
               ", not 1";
    return {};
}

}  // namespace

std::string validate_cache_atlas(const CacheAtlas& a, AtlasMaps maps) {
    if (a.resolution < 1 || a.resolution > kCacheAtlasMaxResolution)
        return "attribute 'resolution' is " + std::to_string(a.resolution) + " (must be 1.." +
               std::to_string(kCacheAtlasMaxResolution) + ")";
    const size_t n = a.size(), n_tex = a.texels();
    for (auto [name, rows] : {std::pair{"normal", a.normal.size()}, std::pair{"photon_count", a.photon_count.size()},
                              std::pair{"radius", a.radius.size()}, std::pair{"usable", a.usable.size()}})
        if (std::string e = h5::check_rows(name, rows, "position", n); !e.empty()) return e;
    for (auto [name, size] : {std::pair{"pdf", a.pdf.size()}, std::pair{"cdf", a.cdf.size()}})
        if (size != n * n_tex && !(maps == AtlasMaps::PdfOnly && name == std::string("cdf") && size == 0))
            return "dataset '" + std::string(name) + "' has " + std::to_string(size) + " values, expected " +
                   std::to_string(n) + " caches x " + std::to_string(n_tex) + " texels (resolution " +
                   std::to_string(a.resolution) + ")";
    if (std::string e = h5::check_finite("position", a.position); !e.empty()) return e;
    if (std::string e = h5::check_unit("normal", a.normal); !e.empty()) return e;
    if (std::string e = h5::check_finite("radius", a.radius); !e.empty()) return e;
    if (!a.caustic_share.empty()) {
        if (std::string e = h5::check_rows("caustic_share", a.caustic_share.size(), "position", n); !e.empty()) return e;
        for (size_t i = 0; i < n; ++i)
            if (!(a.caustic_share[i] >= 0 && a.caustic_share[i] <= 1))
                return "dataset 'caustic_share' is " + std::to_string(a.caustic_share[i]) + " in row " +
                       std::to_string(i) + " (must be in [0, 1])";
    }
    for (size_t i = 0; i < n; ++i) {
        if (a.radius[i] < 0) return "dataset 'radius' is negative in row " + std::to_string(i);
        if (a.usable[i] > 1) return "dataset 'usable' has the value " + std::to_string(a.usable[i]) + " in row " +
                                    std::to_string(i) + " (0 or 1)";
    }
    if (a.k < 0) return "attribute 'k' is negative";
    if (!std::isfinite(a.filter_sigma) || a.filter_sigma < 0) return "attribute 'filter_sigma' is not a finite value >= 0";
    if (!(a.floor >= 0 && a.floor <= 1)) return "attribute 'floor' is " + std::to_string(a.floor) + " (must be in [0, 1])";
    for (size_t i = 0; i < n; ++i)
        if (std::string e = check_map_row(a, i); !e.empty()) return e;
    return {};
}

void write_cache_atlas(const std::string& path, const CacheAtlas& atlas, const std::string& scene_fingerprint,
                       const Provenance& provenance) {
    if (std::string e = validate_cache_atlas(atlas); !e.empty()) throw StageFileError(path + ": refusing to write: " + e);
    h5::Writer w(path, kCacheAtlasFormat, kCacheAtlasVersion, scene_fingerprint, provenance);
    w.attribute_u64("cache_count", atlas.size());
    w.attribute_string("mapping", kCacheAtlasMapping);
    w.attribute_i32("resolution", atlas.resolution);
    w.attribute_i32("k", atlas.k);
    w.attribute_string("filter", atlas.filter);
    w.attribute_f64("filter_sigma", atlas.filter_sigma);
    w.attribute_f64("floor", atlas.floor);
    const size_t n_tex = atlas.texels();
    w.dataset("position", atlas.position, "world units", "cache position, on a surface");
    w.dataset("normal", atlas.normal, "unit vector", "local +z of the cache's map (Duff et al. frame), served side");
    w.dataset("pdf", atlas.pdf, n_tex, "1/sr",
              "density per steradian, constant per texel of the equal-area octahedral map; row sums * 4pi/N = 1");
    w.dataset("cdf", atlas.cdf, n_tex, "1", "running sum of texel probabilities pdf * 4pi/N; last = 1");
    w.dataset("photon_count", atlas.photon_count, "photons", "photons that filled the map");
    w.dataset("radius", atlas.radius, 0, "world units", "gather radius");
    w.dataset("usable", atlas.usable, "bool", "1 = may guide; 0 = too few photons, never sampled");
    if (!atlas.caustic_share.empty())
        w.dataset("caustic_share", atlas.caustic_share, 0, "1",
                  "share of the map's photon power that passed a specular bounce on its way from the light");
    w.commit();
}

CacheAtlasFile read_cache_atlas(const std::string& path, const std::string& expected_fingerprint, AtlasMaps maps) {
    h5::Reader r(path, kCacheAtlasFormat, kCacheAtlasVersion, expected_fingerprint);
    CacheAtlasFile f;
    f.header = r.header();
    CacheAtlas& a = f.atlas;
    if (std::string mapping = r.attribute_string("mapping"); mapping != kCacheAtlasMapping)
        r.fail("unknown mapping '" + mapping + "' (this iris reads '" + kCacheAtlasMapping + "')");
    // Checked before use: the resolution sizes the pdf/cdf rows.
    const int64_t res = r.attribute_int("resolution");
    if (res < 1 || res > kCacheAtlasMaxResolution)
        r.fail("attribute 'resolution' is " + std::to_string(res) + " (must be 1.." +
               std::to_string(kCacheAtlasMaxResolution) + ")");
    a.resolution = int(res);
    const int64_t k = r.attribute_int("k");
    if (k < 0 || k > INT32_MAX) r.fail("attribute 'k' is " + std::to_string(k));
    a.k = int(k);
    a.filter = r.attribute_string("filter");
    a.filter_sigma = r.attribute_double("filter_sigma");
    a.floor = r.attribute_double("floor");
    const uint64_t count = r.attribute_uint("cache_count");
    a.position = r.vec3s("position");
    a.normal = r.vec3s("normal");
    a.pdf = r.floats("pdf", a.texels());
    if (maps == AtlasMaps::PdfAndCdf) a.cdf = r.floats("cdf", a.texels());
    a.photon_count = r.u32s("photon_count");
    a.radius = r.floats("radius", 0);
    a.usable = r.u8s("usable");
    if (r.has_dataset("caustic_share")) a.caustic_share = r.floats("caustic_share", 0);
    if (count != a.size())
        r.fail("attribute 'cache_count' is " + std::to_string(count) + " but dataset 'position' has " +
               std::to_string(a.size()) + " rows");
    // pdf/cdf are stored (n, N): their row counts are compared here, the values in validate.
    const size_t n_tex = a.texels();
    if (std::string e = h5::check_rows("pdf", a.pdf.size() / n_tex, "position", a.size()); !e.empty()) r.fail(e);
    if (maps == AtlasMaps::PdfAndCdf)
        if (std::string e = h5::check_rows("cdf", a.cdf.size() / n_tex, "position", a.size()); !e.empty()) r.fail(e);
    if (std::string e = validate_cache_atlas(a, maps); !e.empty()) r.fail(e);
    return f;
}

StageHeader read_cache_atlas_header(const std::string& path, const std::string& expected_fingerprint) {
    return read_stage_header(path, kCacheAtlasFormat, kCacheAtlasVersion, expected_fingerprint);
}

}  // namespace iris
