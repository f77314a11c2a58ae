#include "tools/fill-caches/cache_filler.h"
#include "libcommon/mutation.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "libcommon/point_tree.h"
#include "libcommon/progress.h"
#include "libcommon/spheremap.h"

namespace iris {

void check_fill_options(const FillOptions& o) {
    if (o.k == 0) throw std::runtime_error("gather-count must be positive");
    if (o.resolution < 1 || o.resolution > kCacheAtlasMaxResolution)
        throw std::runtime_error("map-resolution must be in [1, " + std::to_string(kCacheAtlasMaxResolution) + "]");
    if (!(o.max_radius > 0)) throw std::runtime_error("max-radius must be positive");
    if (!(o.filter_sigma >= 0)) throw std::runtime_error("filter-sigma must be >= 0");
    if (!(o.floor > 0 && o.floor <= 1)) throw std::runtime_error("floor must be in (0, 1]");
    // The floor's texel probability f/N must be representable in the float CDF: near 1 its spacing is
    // 2^-24, and texels whose probability falls below that get an empty CDF interval, i.e. density 0 --
    // breaking "the density is >= f/(4 pi) everywhere" (formats/README.md) and, in nee+cache mode
    // (no BSDF share), biasing the image (found by tests/stress/test_guiding_caches.cpp with f = 1e-6).
    // Two ULPs per texel leave room for rounding.
    const double min_floor = double(o.resolution) * double(o.resolution) * 0x1p-23;
    if (o.floor < min_floor) {
        char msg[160];
        std::snprintf(msg, sizeof msg, "floor %g is below what a float CDF of %dx%d texels can hold (at least %.3g)",
                      o.floor, o.resolution, o.resolution, min_floor);
        throw std::runtime_error(msg);
    }
}

CacheAtlas fill_caches(const CachePoints& caches, const PhotonMap& photons, double diagonal, const FillOptions& o,
                       FillStats* stats) {
    check_fill_options(o);
    auto t0 = std::chrono::steady_clock::now();
    int threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));

    const int R = o.resolution;
    const size_t N = size_t(R) * R;
    CacheAtlas atlas;
    atlas.resolution = R;
    atlas.position = caches.position;
    atlas.normal = caches.normal;
    atlas.pdf.assign(caches.size() * N, 0.0f);
    atlas.cdf.assign(caches.size() * N, 0.0f);
    atlas.photon_count.assign(caches.size(), 0);
    atlas.radius.assign(caches.size(), 0.0f);
    atlas.usable.assign(caches.size(), 0);
    const bool flags = !photons.caustic.empty();
    if (flags) atlas.caustic_share.assign(caches.size(), 0.0f);
    atlas.k = int(o.k);
    atlas.filter = o.filter_sigma > 0 ? "gaussian" : "none";
    atlas.filter_sigma = o.filter_sigma;
    atlas.floor = o.floor;

    const bool skip_direct = !o.direct && !photons.bounces.empty();
    const PointTree tree(photons.position);
    const uint32_t k = uint32_t(std::min<size_t>(o.k, photons.size()));
    const float max_d2 = float(o.max_radius * diagonal) * float(o.max_radius * diagonal);
    // Texel angular size sqrt(4 pi / N) converts the filter width from texels to radians.
    const SphereFilter filter(R, float(o.filter_sigma * std::sqrt(4.0 * M_PI / double(N))));

    struct Scratch {
        std::vector<std::pair<uint32_t, float>> found;
        float r2 = 0;  // the last search radius^2 that held k photons: caches nearby need similar ones
        SphereMap map;
    };
    tbb::enumerable_thread_specific<Scratch> scratch([&] { return Scratch{{}, max_d2 / 64, SphereMap(R)}; });
    // The k nearest photons within the radius limit: a radius search, grown until it holds k photons
    // (or reaches the limit) and shrunk when it holds far more, then a partial sort. Each search is
    // linear in what it finds, unlike a k-nearest search whose result insertion is O(k) per photon.
    auto gather = [&](Scratch& s, Vec3 q) {
        float r2 = std::min(s.r2, max_d2);
        for (int it = 0; it < 40; ++it) {
            tree.within(q, r2, s.found);
            if (s.found.size() < k && r2 < max_d2) {
                r2 = std::min(max_d2, r2 * 2.5f);
                continue;
            }
            if (s.found.size() > 8 * size_t(k) && it < 39) {
                r2 *= 0.3f;
                continue;
            }
            break;
        }
        if (s.found.size() >= k) s.r2 = r2;
        if (s.found.size() > k) {
            std::nth_element(s.found.begin(), s.found.begin() + (k - 1), s.found.end(),
                             [](const auto& a, const auto& b) { return a.second < b.second; });
            s.found.resize(k);
        }
    };
    Progress progress("fill-caches", caches.size(), o.quiet);
    std::atomic<uint64_t> photons_used{0};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, caches.size(), 64), [&](const tbb::blocked_range<size_t>& range) {
        Scratch& s = scratch.local();
        for (size_t c = range.begin(); c != range.end(); ++c) {
            const Vec3 n = caches.normal[c];
            const Frame frame(n);
            s.map.clear();
            gather(s, caches.position[c]);
            uint32_t used = 0;
            float r2 = 0;
            double total_power = 0, caustic_power = 0;
            for (const auto& [p, d2] : s.found) {
                // Same surface, same side (DESIGN 4.6): photon normals face the side they arrived from.
                if (dot(photons.normal[p], n) < o.normal_cos) continue;
                if (skip_direct && photons.bounces[p] == 0) continue;
                float power = luminance(photons.power[p]);
                if (!(power > 0)) continue;
                Vec3 local = frame.to_local(photons.direction[p]);
                if (IRIS_MUTANT(mirrored_cache_map)) local = {-local.x, -local.y, local.z};
                s.map.splat(local, power);
                total_power += power;
                if (flags && photons.caustic[p]) caustic_power += power;
                ++used;
                r2 = std::max(r2, d2);
            }
            atlas.photon_count[c] = used;
            if (flags && total_power > 0) atlas.caustic_share[c] = float(std::min(1.0, caustic_power / total_power));
            atlas.radius[c] = std::sqrt(r2);
            atlas.usable[c] = used >= o.min_photons ? 1 : 0;
            photons_used += used;
            if (atlas.usable[c] && o.filter_sigma > 0) s.map.filter(filter);
            if (!atlas.usable[c]) s.map.clear();  // an unusable cache keeps a valid (uniform) table
            s.map.normalise_floor(float(o.floor));
            SphereDistribution::build(s.map.data(), R, &atlas.cdf[c * N], &atlas.pdf[c * N]);
        }
        progress.advance(range.size());
    });
    uint32_t usable = 0;
    double sum_r = 0;
    for (size_t c = 0; c < caches.size(); ++c)
        if (atlas.usable[c]) {
            ++usable;
            sum_r += atlas.radius[c];
        }
    if (stats) {
        stats->usable = usable;
        stats->unusable = uint32_t(caches.size()) - usable;
        stats->mean_photons = caches.size() ? double(photons_used) / caches.size() : 0;
        stats->mean_radius = usable ? sum_r / usable : 0;
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    progress.finish(std::to_string(usable) + " of " + std::to_string(caches.size()) + " caches usable");
    return atlas;
}

}  // namespace iris
