// render: the iris path tracer's command line. A thin shell over tools/render/integrator.h.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <memory>
#include <thread>

#include "formats/exr.h"
#include "formats/scene_xml.h"
#include "formats/cache_atlas.h"
#include "tools/common/settings.h"
#include "tools/common/tool_util.h"
#include "tools/render/integrator.h"


namespace {

// The settings into the render's options, by the one rule for `auto` (the pilot decides it; where no
// pilot runs -- no atlas, pilot=off or mode=nee+bsdf -- auto means guide-vertices 1, rr-threshold 0.3,
// caustics off, connect off, light-paths 1). max-depth / rr-depth: the scene's unless set; handed to
// render_image as "the scene's" (-2) where they resolve to the scene's value, so that the pilot's
// every-vertex candidate depends on the values only.
void apply_settings(iris::Settings& s, const iris::Scene& scene, bool have_atlas, iris::RenderOptions* opt,
                    iris::GuideOptions* guide) {
    const std::string mode = s.text("mode");
    opt->mode = iris::parse_guide_mode(mode);
    opt->auto_guide = have_atlas && s.on("pilot") && opt->mode != iris::GuideMode::NeeBsdf;
    using C = iris::RenderOptions::Caustics;
    using N = iris::RenderOptions::Connect;
    const bool pilot = opt->auto_guide;
    opt->caustics = s.is("caustics", "on") ? C::On : s.is("caustics", "auto") && pilot ? C::Auto : C::Off;
    opt->connect = s.is("connect", "on") ? N::On : s.is("connect", "auto") && pilot ? N::Auto : N::Off;
    opt->light_paths_per_pixel = s.is("light-paths", "auto") ? 0.0 : s.number("light-paths");
    opt->guide_vertices = s.is("guide-vertices", "auto") ? -1 : int(s.integer("guide-vertices"));
    opt->rr_threshold = s.is("rr-threshold", "auto") ? -1.0f : float(s.number("rr-threshold"));
    const int max_depth = s.is("max-depth", "scene") ? scene.defaults.max_depth : int(s.integer("max-depth"));
    const int rr_depth = s.is("rr-depth", "scene") ? scene.defaults.rr_depth : int(s.integer("rr-depth"));
    if (rr_depth == 0) throw std::runtime_error("setting \"rr-depth\" must be >= 1, or -1 for no Russian roulette");
    opt->max_depth = max_depth == scene.defaults.max_depth ? -2 : max_depth;
    opt->rr_depth = rr_depth == scene.defaults.rr_depth ? -2 : rr_depth;
    s.resolve("max-depth", std::to_string(max_depth));
    s.resolve("rr-depth", std::to_string(rr_depth));
    opt->sampler = s.is("sampler", "sobol") ? iris::RenderOptions::Sampler::Sobol : iris::RenderOptions::Sampler::Independent;
    opt->samples_layer = s.on("samples-layer");
    guide->bsdf_fraction = s.is("bsdf-fraction", "auto") ? -1.0f : float(s.number("bsdf-fraction"));
    guide->min_gain = float(s.number("min-gain"));
    guide->product = s.on("product");
    guide->learn = s.on("learn");
    if (guide->learn && !have_atlas) throw std::runtime_error("setting learn=on needs --atlas");
    if (guide->learn && opt->mode == iris::GuideMode::NeeBsdf) throw std::runtime_error("setting learn=on needs a guided mode");
    if (!have_atlas && opt->mode == iris::GuideMode::NeeCache) throw std::runtime_error("setting mode=nee+cache needs --atlas");
    if (opt->sample_end > 0 && opt->auto_guide)
        throw std::runtime_error("--sample-range needs pilot=off (the pilot's choice is measured per process)");
}

// The settings as the render ran them, in the image's metadata (merge-images compares them), beside
// the pilot's decision (iris:auto_guide). A part's record of what changes a sample (render_image's
// iris:settings) moves to iris:sample_settings.
void record_settings(iris::Image* img, const std::string& record) {
    auto& md = img->metadata;
    auto it = md.find("iris:settings");
    if (it != md.end()) md["iris:sample_settings"] = it->second;
    md["iris:settings"] = record;
}

}  // namespace

int main(int argc, char** argv) {
    iris::RenderOptions opt;
    std::string scene_path, output, resolution, atlas_path;
    iris::GuideOptions guide_options;
    std::vector<std::string> defines, assignments;
    CLI::App app{"render: path-trace a Mitsuba scene into a linear OpenEXR image; with --atlas guided by the "
                 "caches, as a short pilot decides (--list-settings shows every setting)"};
    app.set_version_flag("--version", std::string("iris render ") + IRIS_VERSION);
    app.add_option("scene", scene_path, "Scene file (Mitsuba 0.5 XML)")->required();
    app.add_option("-o,--output", output, "Output image (.exr)")->required();
    app.add_option("--atlas", atlas_path, "Cache atlas from fill-caches: guide the path tracer with it");
    app.add_option("--spp", opt.spp, "Samples per pixel (default: the scene's sampleCount; with --time: a cap)");
    app.add_option("--time", opt.time, "Time budget in seconds, the pilot's included: render passes until it is spent");
    app.add_option("--resolution", resolution, "Image size WxH, overriding the scene's film");
    app.add_option("-t,--threads", opt.threads, "Worker threads (default: all cores)");
    app.add_option("--seed", opt.seed, "Random seed (same seed => same image, for any thread count)");
    iris::add_settings_options(app, iris::kRender, "render", &assignments);
    app.add_flag("--variance", opt.variance_layer, "Add layers variance.R/G/B (variance of each pixel's estimate: sample variance / n; with sampler=sobol as a rule an overstatement)");
    app.add_option("--snapshot", opt.snapshot_interval,
                   "Every SECONDS, write the image so far to the output (atomically), so that an interrupted "
                   "render still leaves a usable image");
    std::string write_atlas;
    app.add_option("--write-atlas", write_atlas,
                   "With learn=on: write the refit cache atlas (photons + path samples) to this HDF5 file, for reuse as --atlas");
    std::string sample_range;
    app.add_option("--sample-range", sample_range,
                   "A:B -- render only samples A..B-1 of each pixel (of the --spp in all), seeded as in one run, and "
                   "store the film's sums so that `merge-images` adds the parts into the image of one run; needs a "
                   "fixed --spp and pilot=off");
    app.add_flag("-q,--quiet", opt.quiet, "No progress output");
    bool no_scene_warnings = false, strict = false;
    iris::add_scene_options(app, &defines, &no_scene_warnings, &strict);
    if (int rc = iris::parse_command_line(app, argc, argv, "render"); rc >= 0) return rc;
    try {
        iris::Settings settings(iris::kRender, "render");
        settings.set_all(assignments);
        if (opt.spp < 0) throw std::runtime_error("--spp must be positive, got " + std::to_string(opt.spp));
        if (opt.time < 0) throw std::runtime_error("--time must be positive");
        if (!(opt.snapshot_interval >= 0 && std::isfinite(opt.snapshot_interval)))
            throw std::runtime_error("--snapshot must be a positive number of seconds");
        if (!sample_range.empty()) {
            uint64_t a = 0, b = 0;
            if (!iris::parse_range(sample_range, &a, &b) || b > (uint64_t(1) << 30))
                throw std::runtime_error("--sample-range must be A:B with 0 <= A < B, got '" + sample_range + "'");
            opt.sample_begin = int(a);
            opt.sample_end = int(b);
        }
        if (!resolution.empty()) iris::parse_resolution(resolution, &opt.width, &opt.height);
        iris::check_output_path(output);
        if (!write_atlas.empty() && !settings.on("learn")) throw std::runtime_error("--write-atlas needs the setting learn=on");
        if (!write_atlas.empty()) iris::check_output_path(write_atlas);
        const bool learn = settings.on("learn");
        if (opt.threads < 0) throw std::runtime_error("--threads must be positive");
        // The thread limit covers loading too: the atlas is decompressed and the guide built in parallel.
        const unsigned threads = opt.threads > 0 ? unsigned(opt.threads) : std::max(1u, std::thread::hardware_concurrency());
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
        iris::SceneLoadOptions lo;
        lo.parameters = iris::parse_defines(defines);
        lo.quiet_warnings = no_scene_warnings;
        lo.strict = strict;
        lo.spectrum_interpolation = settings.is("spectrum-interpolation", "linear")
                                        ? iris::SpectrumInterpolation::Linear
                                        : iris::SpectrumInterpolation::Mitsuba050;
        opt.command_line = iris::join_args(argc, argv);
        iris::Scene scene = iris::load_scene(scene_path, lo);
        apply_settings(settings, scene, !atlas_path.empty(), &opt, &guide_options);
        std::unique_ptr<iris::Guide> guide;
        if (!atlas_path.empty() && opt.mode != iris::GuideMode::NeeBsdf) {
            iris::CacheAtlasFile f = iris::read_cache_atlas(atlas_path, scene.fingerprint, iris::AtlasMaps::PdfOnly);
            guide = std::make_unique<iris::Guide>(std::move(f.atlas), guide_options);
            const iris::GuideSummary& g = guide->summary();
            if (!opt.quiet)
                std::fprintf(stderr, "render: guiding with %zu of %zu caches (%zu usable; mean BSDF share %.2f; maps %.1f MB, "
                             "lookup grids %.1f MB)%s\n",
                             g.guiding, g.caches, g.usable, g.mean_alpha, double(g.table_bytes) / 1e6,
                             double(g.grid_bytes) / 1e6,
                             g.guiding  ? ""
                             : g.caches ? ": none is predicted to beat BSDF sampling, rendering unguided"
                                        : ": the atlas has none (place-caches skipped a scene without light "
                                          "through specular chains), rendering unguided");
            if (opt.sample_end > 0) {
                char buf[160];
                std::snprintf(buf, sizeof buf, "atlas %s; bsdf_fraction %.9g; min_gain %.9g",
                              iris::file_fingerprint(atlas_path).c_str(), double(guide_options.bsdf_fraction),
                              double(guide_options.min_gain));
                opt.settings_extra = buf;
            }
            // A guide without caches would only cost lookups.
            if (!guide->empty()) opt.guide = guide.get();
            if (learn && opt.guide) opt.learn = guide.get();
        }
        const std::string record = settings.record();
        if (opt.snapshot_interval > 0)
            opt.snapshot = [&](const iris::Image& img) {
                iris::Image copy = img;
                record_settings(&copy, record);
                iris::write_exr(output, copy);
            };
        iris::RenderStats stats;
        iris::Image img = iris::render_image(scene, opt, &stats);
        record_settings(&img, record);
        iris::write_exr(output, img);
        if (!write_atlas.empty()) {
            iris::Provenance prov;
            prov.tool = "render";
            prov.tool_version = IRIS_VERSION;
            prov.command_line = opt.command_line;
            prov.inputs = atlas_path + " " + iris::file_fingerprint(atlas_path);
            prov.seed = opt.seed;
            prov.parameters = {{"spp", double(stats.spp)}, {"refits", double(stats.refits)}};
            iris::write_cache_atlas(write_atlas, guide->refined_atlas(), scene.fingerprint, prov);
        }
        if (!opt.quiet && stats.refits > 0)
            std::fprintf(stderr, "render: hybrid caches: %s\n",
                         iris::describe(stats.last_refit, stats.refits, stats.refit_seconds).c_str());
        if (!opt.quiet)
            std::fprintf(stderr, "render: wrote %s (%dx%d, %d spp, %.2f s, %.2f Mpaths/s, %.2f Mrays/s%s)\n",
                         output.c_str(), img.width, img.height, stats.spp, stats.seconds,
                         stats.paths / stats.seconds * 1e-6, stats.rays / stats.seconds * 1e-6,
                         stats.nonfinite ? (", " + std::to_string(stats.nonfinite) + " NaN/Inf samples discarded").c_str()
                                         : "");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "render: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
