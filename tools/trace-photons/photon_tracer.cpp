#include "tools/trace-photons/photon_tracer.h"
#include "libcommon/mutation.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "libcommon/emission.h"
#include "libcommon/progress.h"
#include "libcommon/rng.h"

namespace iris {

namespace {

// One stored photon while tracing (array of structures: a chunk appends whole photons).
struct Photon {
    Vec3 position, direction, normal;
    RGB power;
    uint8_t bounces;
    uint8_t caustic;  // the path from the light passed a Dirac lobe (PhotonMap::caustic)
};

constexpr uint64_t kChunk = 1024;  // paths per work item; photons of a chunk are kept in path order

// Traces one photon path and appends its photons to `out`.
void trace_one(const Scene& scene, const PhotonOptions& o, uint64_t index, std::vector<Photon>& out,
               uint64_t* nonfinite) {
    Rng rng = Rng::for_index(o.seed, Stream::Photons, index);
    float u_sel = rng.next_float();
    Vec2 u_pos{rng.next_float(), rng.next_float()}, u_dir{rng.next_float(), rng.next_float()};
    EmissionSample e;
    if (!sample_emission(scene, u_sel, u_pos, u_dir, &e)) return;
    RGB beta = e.flux / float(o.paths);
    const float cutoff = max_component(beta) * o.cutoff;
    Ray ray;
    ray.d = e.d;
    // The emitter's geometry is at most the scene's scale: the rounding of e.p is relative to that.
    ray.o = (e.n.x == 0 && e.n.y == 0 && e.n.z == 0) ? e.p : offset_ray_origin(e.p, e.n, e.d, scene.scale());
    SurfaceHit hit;
    BsdfScratch bsdf_at_hit;  // textured BSDFs evaluated at the current vertex (scene_bsdf_at)
    bool after_delta = false;  // some bounce so far was specular
    for (int depth = 1; o.max_depth < 0 || depth <= o.max_depth; ++depth) {
        if (!scene.intersect(ray, &hit)) return;
        const Bsdf& bsdf = scene_bsdf_at(scene, hit, &bsdf_at_hit);
        Vec3 wi_world = -ray.d;  // towards the light the photon came from
        if (!bsdf_is_delta(bsdf)) {
            if (!is_finite(beta)) {
                ++*nonfinite;
                return;
            }
            // The normal is stored facing the side the photon arrived from (the photon map contract).
            out.push_back({hit.p, wi_world, dot(hit.ng, wi_world) >= 0 ? hit.ng : -hit.ng, beta,
                           uint8_t(std::min(depth - 1, 255)), uint8_t(after_delta)});
        }
        if (o.max_depth >= 0 && depth == o.max_depth) return;
        Vec3 wo_world;
        bool delta;
        if (!scatter_light_path(hit, bsdf, wi_world, depth, o.rr_depth, rng, &beta, &wo_world, &delta)) return;
        after_delta = after_delta || delta;
        if (!(max_component(beta) > cutoff)) return;
        ray = spawn_ray(hit, wo_world);
    }
}

}  // namespace

PhotonMap trace_photons(const Scene& scene, const PhotonOptions& o, PhotonStats* stats) {
    if (o.paths == 0) throw std::runtime_error("photon-paths must be positive");
    // Far beyond any feasible run; above it the chunk count (paths + kChunk - 1) / kChunk would overflow.
    if (o.paths > (uint64_t(1) << 48)) throw std::runtime_error("photon-paths is too large: " + std::to_string(o.paths));
    // 0 would trace nothing yet write a map claiming N emitted paths; other negatives are no depth.
    if (o.max_depth == 0 || o.max_depth < -1)
        throw std::runtime_error("photon-depth must be -1 (unlimited) or at least 1, got " + std::to_string(o.max_depth));
    if (o.rr_depth < 1) throw std::runtime_error("photon-rr-depth must be at least 1");
    if (!(o.cutoff >= 0 && o.cutoff < 1)) throw std::runtime_error("photon-cutoff must be in [0, 1)");
    if (scene.light_selection.empty()) throw std::runtime_error(scene.source + ": the scene has no light with power");
    const uint64_t first = o.path_end > 0 ? o.path_begin : 0, last = o.path_end > 0 ? o.path_end : o.paths;
    if (!(first < last && last <= o.paths))
        throw std::runtime_error("--path-range " + std::to_string(first) + ":" + std::to_string(last) +
                                 " is not within the " + std::to_string(o.paths) + " paths (0 <= A < B <= photon-paths)");
    int threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));
    const uint64_t chunks = (last - first + kChunk - 1) / kChunk;
    std::vector<std::vector<Photon>> parts(chunks);
    std::atomic<uint64_t> nonfinite{0};
    Progress progress("trace-photons", chunks, o.quiet);
    auto t0 = std::chrono::steady_clock::now();
    tbb::parallel_for(uint64_t(0), chunks, [&](uint64_t c) {
        uint64_t bad = 0;
        std::vector<Photon>& out = parts[c];
        out.reserve(kChunk * 4);
        for (uint64_t i = first + c * kChunk; i < std::min(last, first + (c + 1) * kChunk); ++i) trace_one(scene, o, i, out, &bad);
        nonfinite += bad;
        progress.advance(1);
    });
    size_t total = 0;
    for (auto& p : parts) total += p.size();
    PhotonMap photons;
    photons.emitted_paths = o.paths;
    photons.max_depth = o.max_depth;
    photons.position.reserve(total);
    photons.direction.reserve(total);
    photons.normal.reserve(total);
    photons.power.reserve(total);
    photons.bounces.reserve(total);
    photons.caustic.reserve(total);
    for (auto& part : parts) {
        for (const Photon& ph : part) {
            photons.position.push_back(ph.position);
            photons.direction.push_back(ph.direction);
            photons.normal.push_back(ph.normal);
            photons.power.push_back(IRIS_MUTANT(photon_power_scale) ? ph.power * 1.05f : ph.power);
            photons.bounces.push_back(ph.bounces);
            photons.caustic.push_back(ph.caustic);
        }
        std::vector<Photon>().swap(part);
    }
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    progress.finish(std::to_string(total) + " photons");
    if (stats) {
        stats->paths = last - first;
        stats->photons = total;
        stats->nonfinite = nonfinite;
        stats->seconds = secs;
        stats->emitted_power = RGB(0.0f);
        for (const Light& l : scene.lights) stats->emitted_power += light_power(scene, l);
    }
    return photons;
}

uint64_t paths_for_photons(const Scene& scene, const PhotonOptions& opts, uint64_t photons) {
    if (photons == 0) throw std::runtime_error("photon-count must be positive");
    PhotonOptions probe = opts;
    probe.paths = kProbePaths;
    probe.path_begin = probe.path_end = 0;
    probe.quiet = true;
    PhotonStats stats;
    trace_photons(scene, probe, &stats);
    // No photon stored by the probe: light mostly leaves the scene; the cap bounds the time.
    if (stats.photons == 0) return kMaxPathsForPhotons;
    const double paths = std::ceil(double(photons) * double(kProbePaths) / double(stats.photons));
    return uint64_t(std::clamp(paths, double(kProbePaths), double(kMaxPathsForPhotons)));
}

}  // namespace iris
