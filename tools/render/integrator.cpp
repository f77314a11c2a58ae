#include "tools/render/integrator.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "libcommon/film.h"
#include "libcommon/progress.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"

namespace iris {

namespace {

// Is wo (world) on the side of the geometric normal that its local z says it is on? Shading normals
// can disagree with the true surface; a direction they send "through" the surface is discarded
// (Mitsuba's check), which prevents light leaks at silhouettes of smooth-shaded meshes.
inline bool consistent_side(Vec3 w_world, Vec3 ng, float local_z) { return dot(w_world, ng) * local_z > 0; }

}  // namespace

RGB trace_path(const Scene& scene, const Ray& camera_ray, Rng& rng, const PathSettings& ps, PathCounters& counters) {
    const Guide* guide = ps.guide;
    const bool use_nee = ps.mode != GuideMode::BsdfCache;
    RGB L(0.0f), beta(1.0f);
    Ray ray = camera_ray;
    float prev_pdf = 0;        // density of the technique mix that created `ray` (per steradian)
    bool prev_delta = true;    // camera rays and delta bounces: emitters hit are counted fully
    Vec3 prev_p = ray.o;
    float eta_scale = 1.0f;    // product of relative IORs^2 crossed, for Russian roulette (Mitsuba)
    SurfaceHit hit;
    for (int depth = 1;; ++depth) {
        ++counters.rays;
        if (!scene.intersect(ray, &hit)) {
            if (scene.environment_light >= 0) {
                const Light& env = scene.lights[scene.environment_light];
                RGB le = light_emitted(env, Vec3(0), -ray.d);
                float w = 1.0f;
                if (!prev_delta && use_nee)
                    w = power_heuristic(prev_pdf, light_pdf(scene, uint32_t(scene.environment_light), prev_p,
                                                            Vec3(0), Vec3(0), ray.d));
                L += beta * le * w;
            }
            break;
        }
        Vec3 wi_world = -ray.d;
        // Emission: paths do not end at lights (an emitter may also reflect, DESIGN 4.8).
        if (hit.light >= 0) {
            const Light& light = scene.lights[hit.light];
            RGB le = light_emitted(light, hit.ng, wi_world);
            if (!is_black(le)) {
                float w = 1.0f;
                if (!prev_delta && use_nee)
                    w = power_heuristic(prev_pdf, light_pdf(scene, uint32_t(hit.light), prev_p, hit.p, hit.ng, ray.d));
                L += beta * le * w;
            }
        }
        if (ps.max_depth >= 0 && depth >= ps.max_depth) break;

        const Bsdf& bsdf = scene.bsdfs[hit.bsdf];
        Vec3 wi = hit.frame.to_local(wi_world);
        if (wi.z == 0) break;
        const bool delta_only = bsdf_is_delta(bsdf);
        // Light sampling and its MIS density are evaluated from a point moved off the surface to the
        // side the path is on: on the surface of a sphere light itself, "inside" (sees all of it) and
        // "outside" (sees none of it) would otherwise be decided by rounding.
        const Vec3 ref = offset_ray_origin(hit.p, hit.ng, wi_world, hit.magnitude);

        // The cache serving this vertex, and the probability alpha of BSDF sampling in the one-sample
        // mixture p_mix = alpha p_bsdf + (1 - alpha) p_cache (DESIGN 4.3). alpha = 1: unguided.
        int cache = -1;
        float alpha = 1.0f;
        if (guide && !delta_only) {
            Vec3 n_side = dot(hit.ng, wi_world) >= 0 ? hit.ng : -hit.ng;
            cache = guide->lookup(hit.p, n_side);
            // nee+cache continues from the cache alone, except where the BSDF has a Dirac lobe beside
            // its smooth part (smooth plastic): only BSDF sampling can produce that lobe, so it keeps
            // its share there, or the estimator would miss the mirror reflection (DESIGN 4.4).
            if (cache >= 0)
                alpha = (ps.mode == GuideMode::NeeCache && bsdf.type != BsdfType::Plastic) ? 0.0f
                                                                                          : guide->bsdf_fraction(cache);
        }
        auto mix_pdf = [&](Vec3 wo_local, Vec3 wo_world, float p_bsdf) {
            return cache < 0 ? p_bsdf : alpha * p_bsdf + (1 - alpha) * guide->pdf(cache, wo_world);
        };

        // Next-event estimation (only where the BSDF has a non-delta part), MIS-weighted against the
        // continuation's full mixture density.
        if (use_nee && !delta_only) {
            LightSample ls;
            float u_sel = rng.next_float();
            Vec2 u_light{rng.next_float(), rng.next_float()};
            if (sample_light(scene, ref, u_sel, u_light, &ls) && ls.pdf > 0 && !is_black(ls.radiance)) {
                Vec3 wo = hit.frame.to_local(ls.wi);
                if (consistent_side(ls.wi, hit.ng, wo.z)) {
                    RGB f = bsdf_eval(bsdf, wi, wo);
                    if (!is_black(f)) {
                        Vec3 from = offset_ray_origin(hit.p, hit.ng, ls.wi, hit.magnitude);
                        bool blocked;
                        ++counters.rays;
                        if (std::isinf(ls.dist)) {
                            Ray sr{from, ls.wi, 0.0f, kInf};
                            blocked = scene.occluded(sr);
                        } else {
                            Vec3 to = ls.delta ? ls.p : offset_ray_origin(ls.p, ls.n, -ls.wi);
                            blocked = scene.occluded(from, to);
                        }
                        if (!blocked) {
                            float w = ls.delta ? 1.0f : power_heuristic(ls.pdf, mix_pdf(wo, ls.wi, bsdf_pdf(bsdf, wi, wo)));
                            L += beta * f * ls.radiance * (w / ls.pdf);
                        }
                    }
                }
            }
        }

        // Continue the path: BSDF sampling, or (guided) a one-sample choice between BSDF and cache.
        float uc = rng.next_float();
        Vec2 u{rng.next_float(), rng.next_float()};
        Vec3 wo_world;
        if (cache < 0) {
            BsdfSample bs;
            if (!bsdf_sample(bsdf, wi, u, uc, &bs)) break;
            wo_world = hit.frame.to_world(bs.wo);
            if (!consistent_side(wo_world, hit.ng, bs.wo.z)) break;
            beta *= bs.weight;
            eta_scale *= bs.eta * bs.eta;
            prev_pdf = bs.pdf;
            prev_delta = bs.delta;
        } else {
            Vec3 wo;
            if (uc < alpha) {
                // BSDF technique; uc is rescaled to stay uniform for the BSDF's own lobe choice.
                BsdfSample bs;
                if (!bsdf_sample(bsdf, wi, u, uc / alpha, &bs)) break;
                wo = bs.wo;
                wo_world = hit.frame.to_world(wo);
                if (!consistent_side(wo_world, hit.ng, wo.z)) break;
                eta_scale *= bs.eta * bs.eta;
                if (bs.delta) {
                    // A Dirac lobe can only come from the BSDF technique: no MIS, divide by its choice.
                    beta *= bs.weight / alpha;
                    prev_pdf = bs.pdf;
                    prev_delta = true;
                } else {
                    float p = mix_pdf(wo, wo_world, bs.pdf);
                    if (!(p > 0)) break;
                    beta *= bsdf_eval(bsdf, wi, wo) / p;
                    prev_pdf = p;
                    prev_delta = false;
                }
            } else {
                float p_cache;
                wo_world = guide->sample(cache, u, &p_cache);
                wo = hit.frame.to_local(wo_world);
                if (!(p_cache > 0) || !consistent_side(wo_world, hit.ng, wo.z)) break;
                float p = alpha * bsdf_pdf(bsdf, wi, wo) + (1 - alpha) * p_cache;
                RGB f = bsdf_eval(bsdf, wi, wo);
                if (is_black(f)) break;
                beta *= f / p;
                prev_pdf = p;
                prev_delta = false;
            }
        }
        if (is_black(beta)) break;
        prev_p = ref;
        ray = spawn_ray(hit, wo_world);

        // Russian roulette from rr_depth on, with Mitsuba's survival probability.
        if (depth >= ps.rr_depth) {
            // beta carries the 1/eta^2 radiance scaling of refractions; undo it for the decision only,
            // so paths inside glass are not killed for a change of units.
            float q = std::min(max_component(beta) * eta_scale, 0.95f);
            if (!(rng.next_float() < q)) break;
            beta /= q;
        }
    }
    return L;
}

Image render_image(const Scene& scene, const RenderOptions& opt, RenderStats* stats) {
    const int width = opt.width > 0 ? opt.width : scene.film.width;
    const int height = opt.height > 0 ? opt.height : scene.film.height;
    if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
        throw std::runtime_error("invalid resolution " + std::to_string(width) + "x" + std::to_string(height));
    if (opt.spp < 0) throw std::runtime_error("--spp must be positive, got " + std::to_string(opt.spp));
    if (opt.time < 0 || !std::isfinite(opt.time)) throw std::runtime_error("--time must be a positive number of seconds");
    if (opt.threads < 0) throw std::runtime_error("--threads must be positive");
    Camera camera = scene.camera;
    camera_prepare(camera, width, height);
    PathSettings ps;
    ps.guide = opt.guide;
    ps.mode = opt.guide ? opt.mode : GuideMode::NeeBsdf;
    if (!opt.guide && opt.mode == GuideMode::BsdfCache) ps.mode = GuideMode::BsdfCache;
    ps.max_depth = opt.max_depth >= -1 ? opt.max_depth : scene.defaults.max_depth;
    ps.rr_depth = opt.rr_depth >= -1 ? opt.rr_depth : scene.defaults.rr_depth;
    if (ps.rr_depth < 0) ps.rr_depth = 1 << 30;
    const bool timed = opt.time > 0;
    const int target_spp = opt.spp > 0 ? opt.spp : (timed ? (1 << 30) : scene.defaults.spp);

    int threads = opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));

    FilterSampler filter(scene.film);
    Film film(width, height);
    constexpr int kTile = 16;
    const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
    const int tile_count = tiles_x * tiles_y;
    std::atomic<uint64_t> rays{0}, nonfinite{0};
    const float fwd_near = scene.camera.near_clip, fwd_far = scene.camera.far_clip;

    Progress progress("render", timed ? uint64_t(opt.time * 1000) : uint64_t(target_spp) * tile_count, opt.quiet);
    auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };

    // One pass renders samples [s0, s1) of every pixel. Each sample's random numbers come from
    // (seed, pixel, sample index), so the image does not depend on threads or on how passes are cut.
    auto run_pass = [&](int s0, int s1) {
        tbb::parallel_for(0, tile_count, [&](int tile) {
            PathCounters counters;
            uint64_t bad = 0;
            int tx = tile % tiles_x, ty = tile / tiles_x;
            int x0 = tx * kTile, y0 = ty * kTile;
            int x1 = std::min(width, x0 + kTile), y1 = std::min(height, y0 + kTile);
            for (int y = y0; y < y1; ++y)
                for (int x = x0; x < x1; ++x) {
                    uint64_t pixel = uint64_t(y) * uint64_t(width) + uint64_t(x);
                    for (int s = s0; s < s1; ++s) {
                        Rng rng = Rng::for_index(opt.seed, Stream::Camera, (pixel << 24) ^ uint64_t(s));
                        float w;
                        Vec2 off = filter.sample({rng.next_float(), rng.next_float()}, &w);
                        float fx = x + 0.5f + off.x, fy = y + 0.5f + off.y;
                        Ray ray;
                        ray.o = camera.origin;
                        ray.d = camera_direction(camera, fx, fy, width, height);
                        float cos_fwd = dot(ray.d, camera.forward);
                        ray.tmin = fwd_near / cos_fwd;
                        ray.tmax = fwd_far / cos_fwd;
                        RGB l = trace_path(scene, ray, rng, ps, counters);
                        if (!is_finite(l) || !std::isfinite(w)) {
                            ++bad;  // counted and reported; the sample still counts with zero radiance
                            l = RGB(0.0f);
                            if (!std::isfinite(w)) w = 0;
                        }
                        film.add(x, y, l, w);
                    }
                }
            rays += counters.rays;
            nonfinite += bad;
            if (!timed) progress.advance(uint64_t(s1 - s0));
        });
    };

    // The image as it stands after `spp` samples per pixel (the final one, or a progressive snapshot).
    auto make_image = [&](int spp, double seconds) {
        Image img;
        img.width = width;
        img.height = height;
        // (add_channel may reallocate the channel list: index the data after adding.)
        for (const char* name : {"R", "G", "B"}) img.add_channel(name);
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                RGB v = film.value(x, y);
                size_t i = size_t(y) * width + x;
                for (int c = 0; c < 3; ++c) img.data[c][i] = v[c];
            }
        if (opt.variance_layer) {
            const int first = int(img.channels.size());
            for (const char* name : {"variance.R", "variance.G", "variance.B"}) img.add_channel(name);
            for (int y = 0; y < height; ++y)
                for (int x = 0; x < width; ++x) {
                    RGB v = film.variance(x, y);
                    size_t i = size_t(y) * width + x;
                    for (int c = 0; c < 3; ++c) img.data[first + c][i] = v[c];
                }
        }
        if (opt.samples_layer) {
            auto& S = img.add_channel("samples");
            for (size_t i = 0; i < S.size(); ++i) S[i] = float(film.count[i]);
        }
        img.metadata["iris:spp"] = std::to_string(spp);
        img.metadata["iris:seconds"] = std::to_string(seconds);
        img.metadata["iris:seed"] = std::to_string(opt.seed);
        img.metadata["iris:max_depth"] = std::to_string(ps.max_depth);
        img.metadata["iris:nonfinite_samples"] = std::to_string(nonfinite.load());
        img.metadata["iris:scene"] = scene.source;
        img.metadata["iris:scene_fingerprint"] = scene.fingerprint;
        img.metadata["iris:command_line"] = opt.command_line;
        img.metadata["iris:version"] = IRIS_VERSION;
        img.metadata["iris:tool"] = "render";
        img.metadata["iris:mode"] = guide_mode_name(ps.mode);
        return img;
    };

    // Passes: one for a fixed spp without snapshots (best load balance). Otherwise passes grow
    // geometrically while the cost per sample is learnt, then are sized so that a pass takes at most
    // ~1/8 of the time budget (so a timed render ends close to its budget) and at most about half the
    // snapshot interval (so snapshots come on time). Samples are seeded per (pixel, index), so how the
    // passes are cut does not change the image.
    const bool snapshots = opt.snapshot_interval > 0 && opt.snapshot;
    int spp = 0;
    double last_snapshot = 0;
    int pass = 1;
    while (spp < target_spp) {
        const int n = (timed || snapshots) ? std::min(pass, target_spp - spp) : target_spp;
        run_pass(spp, spp + n);
        spp += n;
        const double t = elapsed();
        progress.advance(0);
        if (spp >= target_spp) break;
        const double per_spp = t / spp;
        double horizon = 1e300;  // the longest a pass should take, seconds
        if (timed) {
            const double remaining = opt.time - t;
            if (remaining < per_spp * 0.5) break;  // another sample would overshoot more than it helps
            horizon = std::min(remaining, opt.time / 8);
        }
        if (snapshots) {
            if (t - last_snapshot >= opt.snapshot_interval) {
                opt.snapshot(make_image(spp, t));
                last_snapshot = elapsed();
            }
            horizon = std::min(horizon, opt.snapshot_interval / 2);
        }
        pass = std::max(1, std::min(int(std::min(horizon / per_spp, 1e9)), pass * 2));
    }
    const double seconds = elapsed();
    progress.finish(std::to_string(spp) + " spp" +
                    (nonfinite ? ", " + std::to_string(nonfinite.load()) + " NaN/Inf samples discarded" : ""));
    Image img = make_image(spp, seconds);
    if (stats) {
        stats->spp = spp;
        stats->seconds = seconds;
        stats->paths = uint64_t(spp) * uint64_t(width) * uint64_t(height);
        stats->rays = rays.load();
        stats->nonfinite = nonfinite.load();
        stats->threads = threads;
    }
    return img;
}

}  // namespace iris
