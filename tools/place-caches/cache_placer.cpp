#include "tools/place-caches/cache_placer.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <climits>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <unordered_set>

#include "libcommon/rng.h"

namespace iris {

namespace {

// A surface vertex of a camera path: position, and the geometric normal turned to face the incoming ray.
struct PathVertex {
    Vec3 p, n;
};

// Walks a BSDF-sampled camera path through film position (fx, fy), specular bounces chosen as the BSDF
// would (Fresnel), and passes each vertex a cache could guide (neither specular nor glass) to `visit`,
// until max_vertices of them, more than max_bounces bounces, or a miss; Russian roulette on the
// throughput from bounce `roulette_from` on.
// Light is not looked at: the walk only asks where a render's paths go.
template <class Visit>
void walk_camera_path(const Scene& scene, const Camera& cam, float fx, float fy, int w, int h, int max_bounces,
                      int max_vertices, int roulette_from, Rng& rng, Visit&& visit) {
    Ray ray = camera_ray(cam, fx, fy, w, h);
    SurfaceHit hit;
    BsdfScratch scratch;
    RGB throughput{1, 1, 1};
    int vertices = 0;
    for (int bounce = 0; bounce <= max_bounces; ++bounce) {
        if (!scene.intersect(ray, &hit)) return;
        const Bsdf& b = scene_bsdf_at(scene, hit, &scratch);
        // (Rough glass is passed through like smooth glass: no cache guides it, bsdf_guidable_share.)
        if (!bsdf_is_delta(b) && !bsdf_transmits(b)) {
            visit(PathVertex{hit.p, dot(hit.ng, ray.d) < 0 ? hit.ng : -hit.ng});
            if (++vertices >= max_vertices) return;
        }
        BsdfSample bs;
        Vec3 wi = hit.frame.to_local(-ray.d);
        if (!bsdf_sample(b, wi, {rng.next_float(), rng.next_float()}, rng.next_float(), &bs)) return;
        throughput = throughput * bs.weight;
        if (bounce >= roulette_from) {
            const float q = std::min(0.95f, max_component(throughput));
            if (!(rng.next_float() < q)) return;
            throughput = throughput * (1 / q);
        }
        ray = spawn_ray(hit, hit.frame.to_world(bs.wo));
    }
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

// Reach grid: a coarse cell plus the side a surface faces (one of the six signed axes). The side keeps a
// wall's outside (whose photons face away from the room) apart from its inside even where both lie in
// the same cell: scenes/window_room's walls are single quads, lit outside, seen inside.
struct ReachKey {
    CellKey c;
    int side;  // 0..5: +x, -x, +y, -y, +z, -z
    bool operator==(const ReachKey& o) const { return c == o.c && side == o.side; }
};
struct ReachHash {
    size_t operator()(const ReachKey& k) const { return CellHash{}(k.c) * 6 + size_t(k.side); }
};

// The side a normal faces most: its dominant signed axis.
int dominant_side(Vec3 n) {
    const float ax = std::fabs(n.x), ay = std::fabs(n.y), az = std::fabs(n.z);
    if (ax >= ay && ax >= az) return n.x >= 0 ? 0 : 1;
    if (ay >= az) return n.y >= 0 ? 2 : 3;
    return n.z >= 0 ? 4 : 5;
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
    if (o.count == 0) throw std::runtime_error("cache-count must be positive");
    if (o.camera_stride < 0) throw std::runtime_error("camera-stride must be >= 0");
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
    if (o.reach_paths < 0) throw std::runtime_error("reach-paths must be >= 0");
    // Reach grid: cells of 1/64 of the scene's diagonal (a few cm to dm on the seed scenes), each marked
    // cell dilated by one in every direction, so the sparse camera paths cover the surfaces between them.
    const Vec3 lo = scene.bounds_min;
    const double diag = length(scene.bounds_max - lo);
    const double reach_h = diag > 0 ? diag / 64 : 1.0;
    std::unordered_set<ReachKey, ReachHash> reach;
    const bool use_reach = o.camera_stride > 0 && o.reach_paths > 0;
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
                // The first non-specular surface, following at most max_specular specular bounces.
                walk_camera_path(scene, cam, fx, fy, w, h, o.max_specular, 1, INT_MAX, rng, [&](PathVertex v) {
                    bp[i] = v.p;
                    bn[i] = v.n;
                    ok[i] = 1;
                });
            }
        });
        for (size_t i = 0; i < bp.size(); ++i)
            if (ok[i]) add(bp[i], bn[i], kCacheFromCamera);
        if (use_reach) {
            // Per block its own vertex list, each path its own stream (indices above the blocks'), so
            // the marked set does not depend on the thread count.
            std::vector<std::vector<std::pair<Vec3, Vec3>>> verts(bp.size());
            tbb::parallel_for(0, by, [&](int y) {
                for (int x = 0; x < bx; ++x) {
                    size_t i = size_t(y) * bx + x;
                    for (int j = 0; j < o.reach_paths; ++j) {
                        Rng rng = Rng::for_index(o.seed, Stream::Caches,
                                                 (1ull << 40) + uint64_t(i) * uint64_t(o.reach_paths) + uint64_t(j));
                        float fx = std::min(float(w), (x + rng.next_float()) * o.camera_stride);
                        float fy = std::min(float(h), (y + rng.next_float()) * o.camera_stride);
                        // Up to 6 bounces or 3 non-specular vertices, roulette after the second bounce.
                        walk_camera_path(scene, cam, fx, fy, w, h, 6, 3, 2, rng,
                                         [&](PathVertex v) { verts[i].push_back({v.p, v.n}); });
                    }
                }
            });
            for (const auto& vs : verts)
                for (const auto& [p, n] : vs) {
                    const CellKey c = cell_of(p, lo, reach_h);
                    // Every side the normal faces at all (up to three), so a photon on a curved or
                    // tilted surface whose dominant side differs still matches; never the opposite one.
                    const float comp[6] = {n.x, -n.x, n.y, -n.y, n.z, -n.z};
                    for (int side = 0; side < 6; ++side) {
                        if (!(comp[side] > 0)) continue;
                        for (int64_t dz = -1; dz <= 1; ++dz)
                            for (int64_t dy = -1; dy <= 1; ++dy)
                                for (int64_t dx = -1; dx <= 1; ++dx)
                                    reach.insert({{c.x + dx, c.y + dy, c.z + dz}, side});
                    }
                }
        }
    }
    uint32_t n_camera = uint32_t(caches.size());
    double cell = 0;
    // Candidates for photon caches: the photons on surfaces camera paths reach (what the render does not
    // visit needs no cache), or all of them without reach paths.
    std::vector<uint32_t> eligible;
    eligible.reserve(pp.size());
    for (uint32_t i = 0; i < uint32_t(pp.size()); ++i)
        if (!use_reach || reach.count({cell_of(pp[i], lo, reach_h), dominant_side(pn[i])})) eligible.push_back(i);
    if (caches.size() < o.count && !eligible.empty()) {
        const size_t want = o.count - caches.size();
        // Spread the rest evenly over the lit surfaces: a grid whose cell size is shrunk until the
        // photons occupy at least `want` cells, then one photon (in a seeded random order) per cell,
        // cells taken in that random order. Density then follows surface area, not photon density, so
        // dim regions get caches too (the thesis took "the first n" photons).
        std::vector<uint32_t> order = eligible;
        Rng rng = Rng::for_index(o.seed, Stream::Caches, ~0ull);
        for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.next_u32() % i]);
        std::vector<uint32_t> probe(order.begin(), order.begin() + std::min<size_t>(order.size(), 400000));
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
        stats->eligible = eligible.size();
        stats->reach_cells = reach.size();
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return caches;
}

}  // namespace iris
