#include "tools/render/render.h"

#include "libcommon/mutation.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>

#include "formats/film_parts.h"
#include "libcommon/film.h"
#include "libcommon/progress.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "tools/render/caustics.h"
#include "tools/render/connections.h"

namespace iris {

namespace {

constexpr int kTile = 16;  // pixels per tile side: a worker's unit of work

// The options resolved against the scene: image size, camera, path settings, samples.
struct Setup {
    int width = 0, height = 0;
    Camera camera;
    PathSettings ps;
    bool timed = false, part = false;
    int target_spp = 0;
};

// A part of a render split across processes is refused where the samples a range holds would depend on a
// measurement made in this process (a clock, a pilot): then the parts of one image could not add up to
// one run.
void check_part(const Scene& scene, const RenderOptions& opt, const Setup& s) {
    const std::string range = std::to_string(opt.sample_begin) + ":" + std::to_string(opt.sample_end);
    if (s.timed) throw std::runtime_error("--sample-range needs a fixed --spp, not --time (a budget is not divisible into ranges)");
    if (opt.auto_guide && opt.guide)
        throw std::runtime_error("--sample-range cannot be used with the pilot (its choice is measured per process); "
                                 "set pilot=off");
    if (opt.caustics == RenderOptions::Caustics::Auto && CausticTracer::possible(scene))
        throw std::runtime_error("--sample-range cannot be used with caustics=auto (its pilot's choice is measured per "
                                 "process); set caustics=on or caustics=off");
    if (opt.snapshot_interval > 0) throw std::runtime_error("--sample-range cannot be used with --snapshot (a snapshot is not a whole part)");
    if (opt.learn)
        throw std::runtime_error("--sample-range cannot be used with learn=on (a sample's maps are refit from the samples "
                                 "before it, which another process does not have)");
    if (!(opt.sample_begin >= 0 && opt.sample_begin < opt.sample_end && opt.sample_end <= s.target_spp))
        throw std::runtime_error("--sample-range " + range + " is not within the " + std::to_string(s.target_spp) +
                                 " samples per pixel of the render (0 <= A < B <= spp)");
    if (opt.sample_end - opt.sample_begin >= kMaxPartSpp)
        throw std::runtime_error("--sample-range " + range + " holds more than " + std::to_string(kMaxPartSpp) + " samples");
}

// Checks the options and resolves them against the scene. Throws std::runtime_error on invalid ones.
Setup resolve(const Scene& scene, const RenderOptions& opt) {
    Setup s;
    s.width = opt.width > 0 ? opt.width : scene.film.width;
    s.height = opt.height > 0 ? opt.height : scene.film.height;
    if (s.width <= 0 || s.height <= 0 || s.width > 65536 || s.height > 65536)
        throw std::runtime_error("invalid resolution " + std::to_string(s.width) + "x" + std::to_string(s.height));
    if (opt.spp < 0) throw std::runtime_error("--spp must be positive, got " + std::to_string(opt.spp));
    if (opt.time < 0 || !std::isfinite(opt.time)) throw std::runtime_error("--time must be a positive number of seconds");
    if (opt.threads < 0) throw std::runtime_error("--threads must be positive");
    s.camera = scene.camera;
    camera_prepare(s.camera, s.width, s.height);
    PathSettings& ps = s.ps;
    ps.guide = opt.guide;
    ps.mode = opt.guide ? opt.mode : GuideMode::NeeBsdf;
    if (opt.guide_vertices < -1) throw std::runtime_error("guide-vertices must be >= 0");
    ps.guide_vertices = opt.guide_vertices < 0 ? 1 : opt.guide_vertices == 0 ? 1 << 30 : opt.guide_vertices;
    if (!opt.guide && opt.mode == GuideMode::BsdfCache) ps.mode = GuideMode::BsdfCache;
    ps.max_depth = opt.max_depth >= -1 ? opt.max_depth : scene.defaults.max_depth;
    if (IRIS_MUTANT(max_depth_one_short) && ps.max_depth > 1) --ps.max_depth;
    ps.rr_depth = opt.rr_depth >= -1 ? opt.rr_depth : scene.defaults.rr_depth;
    if (ps.rr_depth < 0) ps.rr_depth = 1 << 30;
    if (opt.rr_threshold != -1 && !(opt.rr_threshold > 0 && opt.rr_threshold <= 1))
        throw std::runtime_error("rr-threshold must be in (0, 1]");
    ps.rr_threshold = opt.rr_threshold == -1 ? kRouletteThreshold : opt.rr_threshold;
    s.timed = opt.time > 0;
    s.target_spp = opt.spp > 0 ? opt.spp : (s.timed ? (1 << 30) : scene.defaults.spp);
    s.part = opt.sample_end > 0;
    if (s.part) check_part(scene, opt, s);
    return s;
}

int thread_count(const RenderOptions& opt) {
    return opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
}

// One render: its film, counters, techniques and passes (the steps of render_image).
struct Render {
    const Scene& scene;
    const RenderOptions& opt;
    const int width, height;
    const Camera camera;
    PathSettings ps;  // the pilot's choice where it ran
    const bool timed, part;
    const int target_spp;
    const int threads;
    tbb::global_control gc;
    FilterSampler filter;
    Film film;
    const int tiles_x, tiles_y, tile_count;
    std::atomic<uint64_t> rays{0}, lookups{0}, nonfinite{0};
    // The clock starts before the pilot: its time is part of the budget (equal-time comparisons).
    const std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    // Caustics seen directly (caustics.h): light-traced where that is possible and asked for; in Auto
    // the pilot weighs it (and with pilot=on, guiding too) and chooses the light paths per pixel.
    const bool light_possible;
    const CausticTracer caustic_tracer;
    double light_paths_per_pixel = 0;
    float paths_per_vertex = 0;  // n of connections.h; 0: no connections
    GuideDecision decision;
    bool weigh_guiding = false, weigh_light = false;
    uint64_t light_paths_per_sample = 0, pool_paths_per_sample = 0;
    std::unique_ptr<Progress> progress;
    // Hybrid caches: what the guided vertices receive (only while the chosen setting guides).
    std::unique_ptr<PathSamples> path_samples;
    int next_refit = 1;  // samples per pixel after which the maps are next refit
    int refits = 0;
    double refit_seconds = 0;
    RefitSummary last_refit;
    LightVertexPools pools;
    const bool sobol;

    Render(const Scene& sc, const RenderOptions& o, const Setup& s)
        : scene(sc), opt(o), width(s.width), height(s.height), camera(s.camera), ps(s.ps), timed(s.timed), part(s.part),
          target_spp(s.target_spp), threads(thread_count(o)),
          gc(tbb::global_control::max_allowed_parallelism, size_t(threads)), filter(sc.film), film(s.width, s.height),
          tiles_x((s.width + kTile - 1) / kTile), tiles_y((s.height + kTile - 1) / kTile), tile_count(tiles_x * tiles_y),
          light_possible(o.caustics != RenderOptions::Caustics::Off && CausticTracer::possible(sc)),
          caustic_tracer(sc, camera, s.width, s.height, filter, s.ps.max_depth, s.ps.rr_depth),
          sobol(o.sampler == RenderOptions::Sampler::Sobol) {}

    double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
    void choose_techniques();
    void run_pilot();
    void set_up_light_paths();
    void set_up_learning();
    void render_tile(int tile, int s0, int s1);
    void run_samples(int s0, int s1);
    void run_pass(int s0, int s1);
    void refit();
    int run_passes();
    void add_part_metadata(Image& img) const;
    Image make_image(int spp, double seconds) const;
    void fill_stats(RenderStats* stats, int spp, double seconds) const;
};

// The techniques: the light paths per pixel asked for, caustic connections' n, and the pilot where it
// decides.
void Render::choose_techniques() {
    if (opt.light_paths_per_pixel < 0 || !std::isfinite(opt.light_paths_per_pixel))
        throw std::runtime_error("light-paths must be positive");
    light_paths_per_pixel = light_possible && opt.caustics == RenderOptions::Caustics::On
                                ? (opt.light_paths_per_pixel > 0 ? opt.light_paths_per_pixel : 1.0)
                                : 0.0;
    // Caustic connections (connections.h): n from light paths of their own (indices no pass uses), so
    // that the weights depend on no pool; before the pilot, which weighs them.
    if (opt.connect != RenderOptions::Connect::Off && CausticTracer::possible(scene) && ps.mode != GuideMode::BsdfCache) {
        constexpr uint64_t kEstimatePaths = 1 << 15, kEstimateFirst = uint64_t(3) << 61;
        paths_per_vertex = estimate_paths_per_vertex(caustic_tracer, opt.seed, kEstimateFirst, kEstimatePaths);
    }
    weigh_guiding = opt.auto_guide && ps.guide;
    weigh_light = light_possible && opt.caustics == RenderOptions::Caustics::Auto;
    if (weigh_guiding || weigh_light) {
        run_pilot();
    } else if (opt.caustics != RenderOptions::Caustics::Off && !opt.quiet) {
        std::fprintf(stderr, "render: caustics %s\n",
                     light_possible ? "light-traced (caustics=on)"
                                    : "not light-traced: no area light or sky reaches a surface through a specular (Dirac) bounce");
    }
}

// A pilot of ~3 % of a time budget (or the minimum for a fixed spp). Without guiding to weigh it measures
// the setting given, with and without the light tracer.
void Render::run_pilot() {
    const bool expand = opt.guide_vertices < 0 && opt.rr_depth < -1 && opt.rr_threshold == -1;
    std::vector<PathSettings> candidates{ps};
    if (weigh_guiding) {
        candidates[0].guide = nullptr;
        candidates[0].mode = GuideMode::NeeBsdf;
        for (const PathSettings& g : guided_candidates(ps, expand)) candidates.push_back(g);
    }
    decision = decide_guiding(scene, camera, width, height, opt.seed, candidates, timed ? 0.03 * opt.time : 0.0,
                              weigh_light ? &caustic_tracer : nullptr, opt.light_paths_per_pixel,
                              opt.connect == RenderOptions::Connect::Auto ? paths_per_vertex : 0.0f);
    if (!opt.quiet) std::fprintf(stderr, "render: %s\n", describe(decision).c_str());
    ps = decision.candidates[size_t(decision.chosen)].settings;
    if (weigh_light) light_paths_per_pixel = decision.light_paths_per_pixel;
}

// Light paths per pass of one sample per pixel (an integer, so that the film's count is exact), and the
// connections' pools: with the light tracer's paths (or, where it does not run, one light path per pixel
// for the pools alone).
void Render::set_up_light_paths() {
    light_paths_per_sample =
        light_paths_per_pixel > 0
            ? std::max<uint64_t>(1, uint64_t(std::llround(light_paths_per_pixel * double(width) * double(height))))
            : 0;
    if (light_paths_per_sample > 0) film.enable_light(double(light_paths_per_sample));
    ps.light_traced_caustics = light_paths_per_sample > 0;
    if (opt.connect == RenderOptions::Connect::On && paths_per_vertex > 0) {
        ps.connect = true;
        ps.paths_per_vertex = paths_per_vertex;
    }
    pool_paths_per_sample =
        !ps.connect ? 0 : light_paths_per_sample > 0 ? light_paths_per_sample : uint64_t(width) * uint64_t(height);
    if (opt.connect == RenderOptions::Connect::On && !opt.quiet)
        std::fprintf(stderr, "render: caustic connections %s\n",
                     ps.connect ? ("on (" + std::to_string(pool_paths_per_sample) + " light paths per sample pass)").c_str()
                                : "off: no light path reaches a surface through a specular chain from an area light or the sky");
}

void Render::set_up_learning() {
    if (opt.learn && opt.learn != opt.guide) throw std::runtime_error("render: the learning guide must be the guide");
    if (opt.learn && !opt.learn->learning()) throw std::runtime_error("render: the guide was not built to learn");
    if (opt.learn && ps.guide)
        path_samples = std::make_unique<PathSamples>(opt.learn->atlas().size(), opt.learn->atlas().texels());
}

// Samples [s0, s1) of one tile's pixels, sample by sample over the tile: with connections, the tile's
// paths then read one pool at a time.
void Render::render_tile(int tile, int s0, int s1) {
    PathCounters counters;
    uint64_t bad = 0;
    int tx = tile % tiles_x, ty = tile / tiles_x;
    int x0 = tx * kTile, y0 = ty * kTile;
    int x1 = std::min(width, x0 + kTile), y1 = std::min(height, y0 + kTile);
    for (int s = s0; s < s1; ++s) {
        ConnectionPool pool;
        if (ps.connect) pool = pool_of(pools, s);
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                const uint64_t pixel = uint64_t(y) * uint64_t(width) + uint64_t(x);
                Rng rng = Rng::for_index(opt.seed, Stream::Camera, (pixel << 24) ^ uint64_t(s));
                float w;
                Vec2 u_filter;
                FirstVertexSamples first;
                if (sobol) {
                    // Three 2D sequences of the pixel, each with scrambles of its own: sample s is point s
                    // of each, and the shuffled indices pair them at random.
                    const uint64_t h = hash3(opt.seed, uint64_t(Stream::Camera), pixel);
                    u_filter = owen_sobol_2d(uint32_t(s), mix64(h));
                    first.u_continue = owen_sobol_2d(uint32_t(s), mix64(h + 1));
                    first.u_light = owen_sobol_2d(uint32_t(s), mix64(h + 2));
                } else {
                    u_filter = Vec2{rng.next_float(), rng.next_float()};
                }
                Vec2 off = filter.sample(u_filter, &w);
                float fx = x + 0.5f + off.x, fy = y + 0.5f + off.y;
                RGB l = trace_path(scene, camera_ray(camera, fx, fy, width, height), rng, ps, counters, nullptr,
                                   path_samples.get(), ps.connect ? &pool : nullptr, sobol ? &first : nullptr);
                if (!is_finite(l) || !std::isfinite(w)) {
                    ++bad;  // counted and reported; the sample still counts with zero radiance
                    l = RGB(0.0f);
                    if (!std::isfinite(w)) w = 0;
                }
                film.add(x, y, l, w);
            }
    }
    rays += counters.rays;
    lookups += counters.lookups;
    nonfinite += bad;
    if (!timed) progress->advance(uint64_t(s1 - s0));
}

// One pass renders samples [s0, s1) of every pixel. Each sample's random numbers come from (seed, pixel,
// sample index), so the image does not depend on threads or on how passes are cut.
void Render::run_samples(int s0, int s1) {
    tbb::parallel_for(0, tile_count, [&](int tile) { render_tile(tile, s0, s1); });
    if (light_paths_per_sample > 0 && !ps.connect)
        nonfinite += trace_light_paths(caustic_tracer, opt.seed, uint64_t(s0) * light_paths_per_sample,
                                       uint64_t(s1 - s0) * light_paths_per_sample,
                                       [&](const CausticSplat& sp) { film.add_light(sp.pixel, sp.value); }, rays);
}

// With connections, the light paths of a batch of samples come first (they fill its pools, and are
// splatted where the caustics are light-traced), in batches of at most ~1M light paths.
void Render::run_pass(int s0, int s1) {
    if (!ps.connect) return run_samples(s0, s1);
    const int batch = int(std::max<uint64_t>(1, (uint64_t(1) << 20) / pool_paths_per_sample));
    for (int a = s0; a < s1; a += batch) {
        const int b = std::min(s1, a + batch);
        nonfinite += build_pools(caustic_tracer, ps.guide, opt.seed, 0, a, b, pool_paths_per_sample, ps.paths_per_vertex,
                                 &pools,
                                 light_paths_per_sample > 0
                                     ? std::function<void(const CausticSplat&)>(
                                           [&](const CausticSplat& sp) { film.add_light(sp.pixel, sp.value); })
                                     : nullptr,
                                 rays);
        run_samples(a, b);
    }
}

// Hybrid caches: the maps refit from photons and path samples, and the next refit doubled.
void Render::refit() {
    const double t0 = elapsed();
    last_refit = opt.learn->refit(*path_samples);
    refit_seconds += elapsed() - t0;
    ++refits;
    next_refit = next_refit < (1 << 29) ? 2 * next_refit : 1 << 30;
}

// Passes: one for a fixed spp without snapshots (best load balance). Otherwise passes grow geometrically
// while the cost per sample is learnt, then are sized so that a pass takes at most ~1/8 of the time
// budget (so a timed render ends close to its budget) and at most about half the snapshot interval (so
// snapshots come on time). Samples are seeded per (pixel, index), so how the passes are cut does not
// change the image. Returns the samples per pixel taken.
int Render::run_passes() {
    if (part) {
        // One pass of this part's samples, seeded by their indices as in a single run.
        run_pass(opt.sample_begin, opt.sample_end);
        return opt.sample_end - opt.sample_begin;
    }
    const bool snapshots = opt.snapshot_interval > 0 && opt.snapshot;
    int spp = 0;
    double last_snapshot = 0;
    int pass = 1;
    while (spp < target_spp) {
        int n = (timed || snapshots) ? std::min(pass, target_spp - spp) : target_spp - spp;
        // Learning: a pass ends where the maps are refit, so that which maps a sample sees depends on its
        // index only, not on how the time budget cut the passes.
        if (path_samples) n = std::min(n, next_refit - spp);
        run_pass(spp, spp + n);
        spp += n;
        // (Not after the last pass: no sample would see that refit.)
        if (path_samples && spp == next_refit && spp < target_spp) refit();
        const double t = elapsed();
        progress->advance(0);
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
    return spp;
}

// A part's film sums and everything that changes a sample (the range aside): parts merge only where
// these agree.
void Render::add_part_metadata(Image& img) const {
    add_film_parts(img, film);
    img.metadata["iris:sample_range"] = std::to_string(opt.sample_begin) + ":" + std::to_string(opt.sample_end);
    img.metadata["iris:spp_total"] = std::to_string(target_spp);
    img.metadata["iris:light_paths_per_sample"] = std::to_string(light_paths_per_sample);
    img.metadata["iris:variance_layer"] = std::to_string(int(opt.variance_layer));
    img.metadata["iris:samples_layer"] = std::to_string(int(opt.samples_layer));
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "resolution %dx%d; seed %llu; mode %s; max_depth %d; rr_depth %d; rr_threshold %.9g; "
                  "guide_vertices %d; guided %d; light paths per sample %llu; connections %d %.9g; sampler %d; filter %d %.9g %.9g; spp %d",
                  width, height, (unsigned long long)opt.seed, guide_mode_name(ps.mode), ps.max_depth, ps.rr_depth,
                  double(ps.rr_threshold), ps.guide_vertices, ps.guide ? 1 : 0, (unsigned long long)light_paths_per_sample,
                  ps.connect ? 1 : 0, double(ps.paths_per_vertex), int(opt.sampler), int(scene.film.filter),
                  double(scene.film.filter_radius), double(scene.film.filter_stddev), target_spp);
    img.metadata["iris:settings"] = std::string(buf) + (opt.settings_extra.empty() ? "" : "; " + opt.settings_extra);
}

// The image as it stands after `spp` samples per pixel (the final one, or a progressive snapshot).
Image Render::make_image(int spp, double seconds) const {
    Image img;
    add_film_layers(img, film, opt.variance_layer, opt.samples_layer);
    img.metadata["iris:spp"] = std::to_string(spp);
    if (part) add_part_metadata(img);
    img.metadata["iris:seconds"] = std::to_string(seconds);
    img.metadata["iris:seed"] = std::to_string(opt.seed);
    img.metadata["iris:max_depth"] = std::to_string(ps.max_depth);
    img.metadata["iris:nonfinite_samples"] = std::to_string(nonfinite.load());
    img.metadata["iris:rays"] = std::to_string(rays.load());
    img.metadata["iris:cache_lookups"] = std::to_string(lookups.load());
    img.metadata["iris:scene"] = scene.source;
    img.metadata["iris:scene_fingerprint"] = scene.fingerprint;
    img.metadata["iris:command_line"] = opt.command_line;
    img.metadata["iris:version"] = IRIS_VERSION;
    img.metadata["iris:tool"] = "render";
    img.metadata["iris:mode"] = guide_mode_name(ps.mode);
    img.metadata["iris:sampler"] = sobol ? "sobol" : "independent";
    if (weigh_guiding || weigh_light) img.metadata["iris:auto_guide"] = describe(decision);
    else if (opt.auto_guide)  // (without a guide: the atlas had no cache that guides; no pilot ran)
        img.metadata["iris:auto_guide"] = "unguided: no cache in the atlas guides";
    if (ps.guide) img.metadata["iris:guiding"] = describe(ps);
    if (path_samples) img.metadata["iris:hybrid_caches"] = describe(last_refit, refits, refit_seconds);
    img.metadata["iris:light_paths"] = std::to_string(uint64_t(spp) * light_paths_per_sample);
    if (opt.caustics != RenderOptions::Caustics::Off)
        img.metadata["iris:caustics"] = light_paths_per_sample > 0 ? "light-traced, " + std::to_string(light_paths_per_sample) +
                                                                         " light paths per sample pass"
                                                                   : "not light-traced";
    return img;
}

void Render::fill_stats(RenderStats* stats, int spp, double seconds) const {
    stats->decision = decision;
    stats->decided = weigh_guiding || weigh_light;
    stats->spp = spp;
    stats->seconds = seconds;
    stats->paths = uint64_t(spp) * uint64_t(width) * uint64_t(height);
    stats->rays = rays.load();
    stats->nonfinite = nonfinite.load();
    stats->light_paths = uint64_t(spp) * light_paths_per_sample;
    stats->threads = threads;
    stats->refits = refits;
    stats->refit_seconds = refit_seconds;
    stats->last_refit = last_refit;
}

}  // namespace

Image render_image(const Scene& scene, const RenderOptions& opt, RenderStats* stats) {
    Render r(scene, opt, resolve(scene, opt));
    r.choose_techniques();
    r.set_up_light_paths();
    r.progress = std::make_unique<Progress>(
        "render",
        r.timed ? uint64_t(opt.time * 1000) : uint64_t(r.part ? opt.sample_end - opt.sample_begin : r.target_spp) * r.tile_count,
        opt.quiet);
    r.set_up_learning();
    const int spp = r.run_passes();
    const double seconds = r.elapsed();
    r.progress->finish(std::to_string(spp) + " spp" +
                       (r.nonfinite ? ", " + std::to_string(r.nonfinite.load()) + " NaN/Inf samples discarded" : ""));
    Image img = r.make_image(spp, seconds);
    if (stats) r.fill_stats(stats, spp, seconds);
    return img;
}

}  // namespace iris
