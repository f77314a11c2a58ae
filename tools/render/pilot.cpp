#include "tools/render/pilot.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "libcommon/rng.h"
#include "tools/render/caustics.h"
#include "tools/render/connections.h"

namespace iris {

namespace {

// Per pilot pixel: sum and sum of squares of the luminance of its samples, and of the same samples
// without their caustic class (what remains for the path tracer where the light tracer takes it).
struct PilotPixel {
    double sum = 0, sum2 = 0, rest = 0, rest2 = 0;
};

// The pilot's sparse pixel grid: every kPilotStride-th pixel in each direction.
constexpr int kPilotStride = 4;
struct PilotGrid {
    int px, py;
    PilotGrid(int width, int height) : px((width + kPilotStride - 1) / kPilotStride), py((height + kPilotStride - 1) / kPilotStride) {}
    static int coord(int i, int size) { return std::min(size - 1, i * kPilotStride + kPilotStride / 2); }
    size_t count() const { return size_t(px) * size_t(py); }
};

// Adds samples [s0, s1) of every pilot pixel to `acc`; returns the wall seconds taken.
double run_pilot(const Scene& scene, const Camera& camera, int width, int height, int s0, int s1, uint64_t seed,
                 const PathSettings& ps, std::vector<PilotPixel>& acc, const LightVertexPools* pools) {
    const PilotGrid grid(width, height);
    acc.resize(grid.count());
    const auto t0 = std::chrono::steady_clock::now();
    tbb::parallel_for(0, grid.py, [&](int j) {
        PathCounters counters;
        for (int i = 0; i < grid.px; ++i) {
            const int x = PilotGrid::coord(i, width), y = PilotGrid::coord(j, height);
            PilotPixel& pp = acc[size_t(j) * size_t(grid.px) + size_t(i)];
            for (int s = s0; s < s1; ++s) {
                ConnectionPool pool;
                if (ps.connect) pool = pool_of(*pools, s);
                // Streams apart from the image's (sample indices from 2^23 on, which no render reaches);
                // both techniques get the same numbers, which makes their comparison less noisy.
                Rng rng = Rng::for_index(seed, Stream::Camera,
                                         ((uint64_t(y) * uint64_t(width) + uint64_t(x)) << 24) ^ uint64_t((1 << 23) + s));
                const float fx = x + rng.next_float(), fy = y + rng.next_float();
                RGB caustic(0.0f);
                const RGB l = trace_path(scene, camera_ray(camera, fx, fy, width, height), rng, ps, counters, &caustic,
                                         nullptr, ps.connect ? &pool : nullptr);
                const bool ok = is_finite(l) && is_finite(caustic);
                const double v = ok ? double(luminance(l)) : 0.0, r = ok ? double(luminance(l - caustic)) : 0.0;
                pp.sum += v;
                pp.sum2 += v * v;
                pp.rest += r;
                pp.rest2 += r * r;
            }
        }
    });
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The light tracer's pilot: `paths` light paths (indices from 2^62 on, apart from the image's); per pilot
// pixel the sum and sum of squares of the luminance of their splats, and in *total the luminance of all
// splats (every pixel's: a small caustic can fall between pilot pixels). Returns the wall seconds taken.
double run_light_pilot(const CausticTracer& tracer, int width, int height, uint64_t seed, uint64_t paths,
                       std::vector<PilotPixel>& acc, double* total) {
    const PilotGrid grid(width, height);
    acc.assign(grid.count(), PilotPixel{});
    std::vector<int32_t> slot(size_t(width) * size_t(height), -1);
    for (int j = 0; j < grid.py; ++j)
        for (int i = 0; i < grid.px; ++i)
            slot[size_t(PilotGrid::coord(j, height)) * size_t(width) + size_t(PilotGrid::coord(i, width))] =
                int32_t(size_t(j) * size_t(grid.px) + size_t(i));
    std::atomic<uint64_t> rays{0};
    const auto t0 = std::chrono::steady_clock::now();
    // (A path that splats one pixel twice -- two of its vertices, rare -- counts as two paths here.)
    trace_light_paths(tracer, seed, uint64_t(1) << 62, paths,
                      [&](const CausticSplat& s) {
                          const double v = luminance(s.value);
                          *total += v;
                          if (const int32_t k = slot[s.pixel]; k >= 0) {
                              acc[size_t(k)].sum += v;
                              acc[size_t(k)].sum2 += v * v;
                          }
                      },
                      rays);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<PathSettings> guided_candidates(const PathSettings& guided, bool expand) {
    std::vector<PathSettings> c{guided};
    if (expand) {
        PathSettings deep = guided;
        deep.guide_vertices = 1 << 30;
        deep.rr_threshold = std::min(guided.rr_threshold, kDeepRouletteThreshold);
        c.push_back(deep);
    }
    return c;
}

size_t pick_candidate(const std::vector<double>& ratio, const std::vector<int>& guide_vertices) {
    const size_t n = ratio.size();
    if (n < 2) return 0;
    int deepest = 0;
    for (size_t c = 1; c < n; ++c) deepest = std::max(deepest, guide_vertices[c]);
    auto rank = [&](size_t c) { return guide_vertices[c] < deepest ? ratio[c] / kShallowMargin : ratio[c]; };
    size_t best = 1;
    for (size_t c = 2; c < n; ++c)
        if (rank(c) > rank(best)) best = c;
    return ratio[best] > kGuideMargin * ratio[0] ? best : 0;
}

bool take_connections(double with, double without, bool without_traced) {
    return without_traced ? with * kConnectTolerance >= without : with > kConnectMargin * without;
}

std::string describe(const PathSettings& s) {
    std::string v = s.guide_vertices >= (1 << 29) ? "every vertex"
                    : s.guide_vertices == 1       ? "first vertex"
                                                  : "first " + std::to_string(s.guide_vertices) + " vertices";
    if (s.rr_depth < (1 << 29)) {
        char buf[64];
        std::snprintf(buf, sizeof buf, ", roulette below %g from depth %d", s.rr_threshold, s.rr_depth);
        v += buf;
    }
    if (s.connect) v += ", caustic connections";
    return v;
}

namespace {

// Passes of 2 samples per pilot pixel alternate between the candidates (so none alone pays for cold
// caches or a busy machine) until the budget is spent, with at least kMinSpp and at most kMaxSpp samples
// per pilot pixel: rare bright paths (caustics, fireflies) dominate relMSE, and only enough samples see
// them.
constexpr int kPass = 2, kMinSpp = 8, kMaxSpp = 256;

// What the pilot measured: per candidate the pilot pixels' sums and the seconds taken; the light
// tracer's per pilot pixel and in total.
struct PilotRun {
    std::vector<std::vector<PilotPixel>> acc;
    std::vector<double> seconds;
    int spp = 0;
    double total = 0;  // wall seconds of the whole pilot
    std::vector<PilotPixel> lacc;
    uint64_t light_paths = 0;
    double light_total = 0;
};

// The candidates as measured: each as given, seeing every path (the pilot splits them), and where
// connections are weighed (*weigh_connect) each guided one again with them.
GuideDecision initial_decision(const std::vector<PathSettings>& candidates, const CausticTracer* light,
                               float paths_per_vertex, bool* weigh_connect) {
    GuideDecision d;
    for (const PathSettings& c : candidates) {
        d.candidates.push_back({c});
        d.candidates.back().settings.light_traced_caustics = false;  // the pilot sees every path; it splits them
    }
    d.guided_choice = candidates.size() > 1;
    // Caustic connections (connections.h): each guided candidate also with them, always with the light
    // tracer (whose paths fill the pools in the render).
    *weigh_connect = d.guided_choice && light && paths_per_vertex > 0;
    if (*weigh_connect)
        for (size_t c = 1, n = d.candidates.size(); c < n; ++c) {
            d.candidates.push_back(d.candidates[c]);
            d.candidates.back().settings.connect = true;
            d.candidates.back().settings.paths_per_vertex = paths_per_vertex;
        }
    return d;
}

// The camera paths' pilot, pass after pass (kPass). With connections, the pilot's pools: kPoolPaths light
// paths per sample index, from indices of their own.
void run_camera_pilots(const Scene& scene, const Camera& camera, int width, int height, uint64_t seed,
                       const GuideDecision& d, const PathSettings& first_guided, double budget_seconds,
                       const CausticTracer* light, float paths_per_vertex, bool weigh_connect, PilotRun& r) {
    constexpr uint64_t kPoolPaths = 1 << 13, kPoolFirst = uint64_t(5) << 60;
    LightVertexPools pools;
    std::atomic<uint64_t> pool_rays{0};
    const size_t n_cand = d.candidates.size();
    r.acc.resize(n_cand);
    r.seconds.assign(n_cand, 0.0);
    while (r.spp < kMaxSpp && (r.spp < kMinSpp || r.total < budget_seconds)) {
        if (weigh_connect) {
            const auto t0 = std::chrono::steady_clock::now();
            build_pools(*light, first_guided.guide, seed, kPoolFirst, r.spp, r.spp + kPass, kPoolPaths, paths_per_vertex,
                        &pools, nullptr, pool_rays);
            r.total += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        }
        for (size_t c = 0; c < n_cand; ++c) {
            const double t = run_pilot(scene, camera, width, height, r.spp, r.spp + kPass, seed, d.candidates[c].settings,
                                       r.acc[c], &pools);
            r.seconds[c] += t;
            r.total += t;
        }
        r.spp += kPass;
    }
}

// Relative noise summed over the pilot pixels: per candidate, without the caustic class, the light
// tracer's; and the mean pixel of candidate 0.
struct PilotNoise {
    std::vector<double> rel, rel_rest;
    double rel_light = 0, camera_mean = 0;
};

// Relative noise of each against the same per-pixel value, so that all are judged on the same scale,
// what relMSE against a reference weighs: the mean of all candidates' samples over the pilot pixel and
// its 8 neighbours. The pixel's own mean would not do: one rare bright sample (a caustic path found by
// BSDF sampling) raises it with the variance, so that variance / mean^2 stays near the sample count
// however heavy the tail, and the pilot would judge unguided sampling far less noisy than it is exactly
// where guiding helps. Measured over 4 seeds on the six seed scenes: this keeps the egg's predicted
// variance ratio at 1.5-1.8 where the own mean gave 1.3 (its equal-spp renders: ~2) and moves no other
// scene's by more than 10 %.
PilotNoise measure_noise(const PilotRun& r, int width, int height, bool light) {
    const PilotGrid grid(width, height);
    const int px = grid.px, py = grid.py, spp = r.spp;
    const size_t n_cand = r.acc.size();
    PilotNoise s;
    s.rel.assign(n_cand, 0.0);
    s.rel_rest.assign(n_cand, 0.0);
    auto var = [](double sum, double sum2, double n) { return std::max(0.0, (sum2 - sum * sum / n) / (n - 1)); };
    for (int j = 0; j < py; ++j)
        for (int i = 0; i < px; ++i) {
            double sum = 0;
            int count = 0;
            for (int y = std::max(0, j - 1); y <= std::min(py - 1, j + 1); ++y)
                for (int x = std::max(0, i - 1); x <= std::min(px - 1, i + 1); ++x, ++count)
                    for (size_t c = 0; c < n_cand; ++c) sum += r.acc[c][size_t(y) * size_t(px) + size_t(x)].sum;
            const double m = sum / (double(n_cand) * spp * count), norm = m * m + 0.01;
            const size_t k = size_t(j) * size_t(px) + size_t(i);
            for (size_t c = 0; c < n_cand; ++c) {
                const PilotPixel& a = r.acc[c][k];
                s.rel[c] += var(a.sum, a.sum2, spp) / norm;
                s.rel_rest[c] += var(a.rest, a.rest2, spp) / norm;
            }
            s.camera_mean += r.acc[0][k].sum / spp;
            if (light) {
                // Per light path; a pass of one light path per pixel traces width x height of them, so its
                // noise per camera sample is the per-path variance over that many.
                const PilotPixel& a = r.lacc[k];
                s.rel_light += var(a.sum, a.sum2, double(r.light_paths)) / (double(width) * height) / norm;
            }
        }
    return s;
}

// noise x time of each candidate without (off) and, where the light tracer is weighed, with it (on, at
// f light paths per pixel and pass).
struct Predicted {
    std::vector<double> off, on, f;
};

// Fills the candidates' measurements and predicts each one's noise x time.
Predicted predict(GuideDecision& d, const PilotRun& r, const PilotNoise& s, double pixels, bool light,
                  double light_paths_per_pixel) {
    const size_t n_cand = d.candidates.size();
    const double n = pixels * r.spp, t_light = d.light_seconds_per_path;
    Predicted p{std::vector<double>(n_cand), std::vector<double>(n_cand, 0.0), std::vector<double>(n_cand, 0.0)};
    for (size_t c = 0; c < n_cand; ++c) {
        auto& k = d.candidates[c];
        k.rel_variance = s.rel[c] / pixels;
        k.rel_variance_rest = s.rel_rest[c] / pixels;
        k.seconds_per_sample = r.seconds[c] / n;
        p.off[c] = k.rel_variance * k.seconds_per_sample;
        if (light) {
            double f = light_paths_per_pixel;
            if (!(f > 0)) {
                const double v = k.rel_variance_rest, vl = d.light_rel_variance;
                f = v > 0 && t_light > 0 ? std::sqrt(vl * k.seconds_per_sample / (v * t_light)) : kMaxLightPathsPerPixel;
                f = std::clamp(f, kMinLightPathsPerPixel, kMaxLightPathsPerPixel);
            }
            p.f[c] = f;
            p.on[c] = (k.rel_variance_rest + d.light_rel_variance / f) * (k.seconds_per_sample + f * t_light);
        }
    }
    return p;
}

// The choice from the predictions: ratios against candidate 0 without the light tracer (a scene without
// noise at all, 0/0, keeps candidate 0). Light tracing where the caustic class is a visible share of the
// image (kMinCausticShare), or where the pilot predicts a gain by a margin (it costs every pass). The
// share decides on its own because the pilot's camera samples rarely see the path tracer's estimate of
// that class at all: it is made of the rare bright samples that find a small light through glass
// (measured on the glass egg: class 0.3 % of the image, absent from 144 pilot samples on every 16th
// pixel, yet the remedy for most of its plain relMSE). Then guided only by a margin over candidate 0
// (the pilot is noisy, and losing is worse than not winning).
void choose(GuideDecision& d, const Predicted& p, bool light) {
    const size_t n_cand = d.candidates.size();
    auto ratio = [&](double nt) { return nt > 0 ? p.off[0] / nt : (p.off[0] > 0 ? 1e30 : 1.0); };
    d.light_share_decides = light && d.light_share >= kMinCausticShare;
    std::vector<double> best_ratio(n_cand);
    std::vector<char> traced(n_cand, 0);
    for (size_t c = 0; c < n_cand; ++c) {
        best_ratio[c] = ratio(p.off[c]);
        if (d.candidates[c].settings.connect) {
            // Only with the light tracer; where taken, in place of the same candidate without them.
            const size_t twin = c - (n_cand - 1) / 2;
            if (take_connections(ratio(p.on[c]), best_ratio[twin], traced[twin] != 0)) {
                best_ratio[c] = ratio(p.on[c]);
                best_ratio[twin] = 0.0;
            } else {
                best_ratio[c] = 0.0;
            }
            traced[c] = 1;
        } else if (light && (d.light_share_decides || ratio(p.on[c]) > kLightMargin * best_ratio[c])) {
            best_ratio[c] = ratio(p.on[c]);
            traced[c] = 1;
        }
    }
    std::vector<int> guide_vertices(n_cand);
    for (size_t c = 0; c < n_cand; ++c) guide_vertices[c] = d.candidates[c].settings.guide_vertices;
    const size_t best = pick_candidate(best_ratio, guide_vertices);
    d.chosen = int(best);
    d.efficiency_ratio = best_ratio[best];
    d.light_trace = traced[best] != 0;
    d.light_paths_per_pixel = d.light_trace ? p.f[best] : 0.0;
}

}  // namespace

GuideDecision decide_guiding(const Scene& scene, const Camera& camera, int width, int height, uint64_t seed,
                             const std::vector<PathSettings>& candidates, double budget_seconds,
                             const CausticTracer* light, double light_paths_per_pixel, float paths_per_vertex) {
    bool weigh_connect = false;
    GuideDecision d = initial_decision(candidates, light, paths_per_vertex, &weigh_connect);
    PilotRun r;
    run_camera_pilots(scene, camera, width, height, seed, d, weigh_connect ? candidates[1] : candidates[0],
                      budget_seconds, light, paths_per_vertex, weigh_connect, r);
    // The light tracer's pilot: one light path per 4 pixels (at least 2^17, so that rare caustics
    // through small glass objects are seen).
    if (light) {
        r.light_paths = std::max<uint64_t>(uint64_t(width) * uint64_t(height) / 4, 1 << 17);
        const double t = run_light_pilot(*light, width, height, seed, r.light_paths, r.lacc, &r.light_total);
        r.total += t;
        d.light_weighed = true;
        d.light_pilot_paths = r.light_paths;
        d.light_seconds_per_path = t / double(r.light_paths);
    }
    PilotNoise s = measure_noise(r, width, height, light != nullptr);
    const double pixels = double(std::max<size_t>(1, PilotGrid(width, height).count()));
    d.pilot_seconds = r.total;
    d.pilot_spp = r.spp;
    d.light_rel_variance = s.rel_light / pixels;
    // Every light path estimates the whole image: its mean pixel is the splats' total over paths and pixels.
    const double light_mean = light ? r.light_total / double(r.light_paths) / (double(width) * height) : 0.0;
    s.camera_mean /= pixels;
    d.light_share = s.camera_mean > 0 ? light_mean / s.camera_mean : 0.0;
    choose(d, predict(d, r, s, pixels, light != nullptr, light_paths_per_pixel), light != nullptr);
    return d;
}

std::string describe(const GuideDecision& d) {
    // e.g. "guided (first vertex, roulette below 0.3 from depth 5), caustics light-traced (0.5 light paths
    // per pixel): pilot predicts 1.35x the efficiency of unguided sampling (relative variance [without
    // the caustics], us per sample: unguided 26 [20], 0.87; first vertex, ... 15 [9], 1.1; ...; light
    // tracer 0.5 per path per pixel, 0.12 us per path)"
    const auto& chosen = d.candidates.at(size_t(d.chosen));
    auto name_of = [](const PathSettings& p) { return p.guide ? describe(p) : std::string("unguided"); };
    std::string s = chosen.settings.guide ? "guided (" + describe(chosen.settings) + ")" : "unguided";
    char buf[200];
    if (d.light_weighed) {
        if (d.light_trace)
            std::snprintf(buf, sizeof buf, ", caustics light-traced (%.3g light paths per pixel; %s)", d.light_paths_per_pixel,
                          d.light_share_decides ? "their share of the image" : "predicted gain");
        else
            std::snprintf(buf, sizeof buf, ", caustics not light-traced");
        s += buf;
    }
    std::snprintf(buf, sizeof buf, ": pilot predicts %.2fx the efficiency of %s sampling%s (", d.efficiency_ratio,
                  d.guided_choice ? "unguided" : "plain", d.guided_choice && !d.guide() ? " for this choice" : "");
    s += buf;
    s += d.light_weighed ? "relative variance [without the caustic class], us per sample:" : "relative variance, us per sample:";
    for (size_t c = 0; c < d.candidates.size(); ++c) {
        const auto& k = d.candidates[c];
        const std::string name = name_of(k.settings);
        if (d.light_weighed)
            std::snprintf(buf, sizeof buf, "%s %s %.3g [%.3g], %.3g", c ? ";" : "", name.c_str(), k.rel_variance,
                          k.rel_variance_rest, k.seconds_per_sample * 1e6);
        else
            std::snprintf(buf, sizeof buf, "%s %s %.3g, %.3g", c ? ";" : "", name.c_str(), k.rel_variance,
                          k.seconds_per_sample * 1e6);
        s += buf;
    }
    if (d.light_weighed) {
        std::snprintf(buf, sizeof buf, "; light tracer %.3g at one path per pixel, %.3g us per path, caustic class %.2f %% of the image",
                      d.light_rel_variance, d.light_seconds_per_path * 1e6, 100 * d.light_share);
        s += buf;
    }
    std::snprintf(buf, sizeof buf, "; pilot %d spp on every 16th pixel%s, %.2f s)", d.pilot_spp,
                  d.light_weighed ? (", " + std::to_string(d.light_pilot_paths) + " light paths").c_str() : "",
                  d.pilot_seconds);
    return s + buf;
}

}  // namespace iris
