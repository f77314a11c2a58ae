#include "tools/place-caches/cache_placer.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "libcommon/rng.h"

namespace iris {

namespace {

// The first non-specular surface seen through film position (fx, fy), following specular bounces.
bool camera_cache(const Scene& scene, const Camera& cam, float fx, float fy, int w, int h, int max_specular,
                  Rng& rng, Vec3* position, Vec3* normal) {
    Ray ray = camera_ray(cam, fx, fy, w, h);
    SurfaceHit hit;
    Bsdf scratch;
    for (int bounce = 0; bounce <= max_specular; ++bounce) {
        if (!scene.intersect(ray, &hit)) return false;
        const Bsdf& b = scene_bsdf_at(scene, hit, &scratch);
        if (!bsdf_is_delta(b)) {
            *position = hit.p;
            *normal = dot(hit.ng, ray.d) < 0 ? hit.ng : -hit.ng;
            return true;
        }
        // Specular: reflect or refract as the BSDF would (chosen by Fresnel), and keep going.
        BsdfSample bs;
        Vec3 wi = hit.frame.to_local(-ray.d);
        if (!bsdf_sample(b, wi, {rng.next_float(), rng.next_float()}, rng.next_float(), &bs)) return false;
        Vec3 wo = hit.frame.to_world(bs.wo);
        ray = spawn_ray(hit, wo);
    }
    return false;
}

struct CellKey {
    int64_t x, y, z;
    bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
    size_t operator()(const CellKey& k) const {
        return size_t(hash3(uint64_t(k.x), uint64_t(k.y), uint64_t(k.z)));
    }
};

CellKey cell_of(Vec3 p, Vec3 origin, double h) {
    return {int64_t(std::floor((p.x - origin.x) / h)), int64_t(std::floor((p.y - origin.y) / h)),
            int64_t(std::floor((p.z - origin.z) / h))};
}

// Number of distinct grid cells of size h that photons (a subset) fall into.
size_t occupied_cells(const std::vector<Vec3>& pts, const std::vector<uint32_t>& subset, Vec3 origin, double h) {
    std::unordered_map<CellKey, uint32_t, CellHash> cells;
    cells.reserve(subset.size());
    for (uint32_t i : subset) cells.emplace(cell_of(pts[i], origin, h), i);
    return cells.size();
}

}  // namespace

CachePoints place_caches(const Scene& scene, const PhotonMap& photons, const PlacementOptions& o,
                         PlacementStats* stats) {
    const std::vector<Vec3>& pp = photons.position;
    const std::vector<Vec3>& pn = photons.normal;
    if (o.count == 0) throw std::runtime_error("--count must be positive");
    if (o.camera_stride < 0) throw std::runtime_error("--camera-stride must be >= 0");
    if (pp.size() != pn.size()) throw std::runtime_error("photon positions and normals differ in length");
    auto t0 = std::chrono::steady_clock::now();
    int threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));
    const int w = o.width > 0 ? o.width : scene.film.width, h = o.height > 0 ? o.height : scene.film.height;
    Camera cam = scene.camera;
    camera_prepare(cam, w, h);

    CachePoints caches;
    auto add = [&](Vec3 p, Vec3 n, uint8_t origin) {
        caches.position.push_back(p);
        caches.normal.push_back(n);
        caches.origin.push_back(origin);
    };
    if (o.camera_stride > 0) {
        const int bx = (w + o.camera_stride - 1) / o.camera_stride, by = (h + o.camera_stride - 1) / o.camera_stride;
        std::vector<Vec3> bp(size_t(bx) * by), bn(size_t(bx) * by);
        std::vector<uint8_t> ok(bp.size(), 0);
        tbb::parallel_for(0, by, [&](int y) {
            for (int x = 0; x < bx; ++x) {
                size_t i = size_t(y) * bx + x;
                Rng rng = Rng::for_index(o.seed, Stream::Caches, i);
                // A jittered position inside the block, so caches do not line up on a regular grid.
                float fx = std::min(float(w), (x + rng.next_float()) * o.camera_stride);
                float fy = std::min(float(h), (y + rng.next_float()) * o.camera_stride);
                ok[i] = camera_cache(scene, cam, fx, fy, w, h, o.max_specular, rng, &bp[i], &bn[i]);
            }
        });
        for (size_t i = 0; i < bp.size(); ++i)
            if (ok[i]) add(bp[i], bn[i], kCacheFromCamera);
    }
    uint32_t n_camera = uint32_t(caches.size());
    double cell = 0;
    if (caches.size() < o.count && !pp.empty()) {
        const size_t want = o.count - caches.size();
        // Spread the rest evenly over the lit surfaces: a grid whose cell size is shrunk until the
        // photons occupy at least `want` cells, then one photon (in a seeded random order) per cell,
        // cells taken in that random order. Density then follows surface area, not photon density, so
        // dim regions get caches too (the thesis took "the first n" photons).
        std::vector<uint32_t> order(pp.size());
        std::iota(order.begin(), order.end(), 0u);
        Rng rng = Rng::for_index(o.seed, Stream::Caches, ~0ull);
        for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.next_u32() % i]);
        std::vector<uint32_t> probe(order.begin(), order.begin() + std::min<size_t>(order.size(), 400000));
        Vec3 lo = scene.bounds_min, hi = scene.bounds_max;
        double diag = length(hi - lo);
        double hsize = diag > 0 ? diag / 4 : 1.0;
        for (int it = 0; it < 60 && occupied_cells(pp, probe, lo, hsize) < want; ++it) hsize /= 1.25;
        cell = hsize;
        std::unordered_map<CellKey, uint32_t, CellHash> taken;
        taken.reserve(want * 2);
        for (uint32_t i : order) {
            if (taken.size() >= want) break;
            CellKey k = cell_of(pp[i], lo, hsize);
            if (taken.emplace(k, i).second) add(pp[i], pn[i], kCacheFromPhoton);
        }
    }
    if (stats) {
        stats->camera = n_camera;
        stats->photon = uint32_t(caches.size()) - n_camera;
        stats->cell_size = cell;
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return caches;
}

}  // namespace iris
