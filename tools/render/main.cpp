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
#include "libcommon/tool_util.h"
#include "tools/render/integrator.h"


int main(int argc, char** argv) {
    iris::RenderOptions opt;
    std::string scene_path, output, resolution, atlas_path, mode = "nee+bsdf+cache";
    std::string bsdf_fraction = "auto";
    iris::GuideOptions guide_options;
    std::vector<std::string> defines;
    CLI::App app{"render: path-trace a Mitsuba scene (NEE + BSDF sampling, MIS) into a linear OpenEXR image"};
    app.set_version_flag("--version", std::string("iris render ") + IRIS_VERSION);
    app.add_option("scene", scene_path, "Scene file (Mitsuba 0.5 XML)")->required();
    app.add_option("-o,--output", output, "Output image (.exr)")->required();
    app.add_option("--spp", opt.spp, "Samples per pixel (default: the scene's sampleCount; with --time: a cap)");
    app.add_option("--time", opt.time, "Time budget in seconds: render passes until it is spent");
    app.add_option("--resolution", resolution, "Image size WxH, overriding the scene's film");
    app.add_option("-t,--threads", opt.threads, "Worker threads (default: all cores)");
    app.add_option("--seed", opt.seed, "Random seed (same seed => same image, for any thread count)");
    app.add_option("--max-depth", opt.max_depth, "Longest path in edges, -1 = unlimited (default: the scene's)");
    app.add_option("--rr-depth", opt.rr_depth, "Depth at which Russian roulette starts, -1 = none (default: the scene's)");
    app.add_option("--rr-threshold", opt.rr_threshold,
                   "Throughput below which Russian roulette plays, in (0, 1]; 1 = Mitsuba's rule (default 0.3)");
    app.add_flag("--variance", opt.variance_layer, "Add layers variance.R/G/B (variance of each pixel's estimate: sample variance / n; with --sampler sobol as a rule an overstatement)");
    app.add_flag("--sample-count", opt.samples_layer, "Add a layer 'samples' with the samples per pixel");
    app.add_option("--atlas", atlas_path, "Cache atlas from fill-caches: guide the path tracer with it");
    app.add_option("--mode", mode,
                   "How sampling techniques combine: nee+bsdf | nee+cache | bsdf+cache | nee+bsdf+cache "
                   "(default with --atlas; without an atlas: nee+bsdf, or bsdf+cache = BSDF sampling only) | auto "
                   "(with --atlas: a short pilot measures nee+bsdf and nee+bsdf+cache -- guiding the first vertex, "
                   "and unless --guide-vertices, --rr-depth or --rr-threshold is given also every vertex with "
                   "Russian roulette below throughput 0.1 -- and renders with the one predicted to win at equal time; the pilot "
                   "counts in --time)");
    app.add_option("--bsdf-fraction", bsdf_fraction,
                   "Probability of BSDF sampling where a cache guides: auto (default: chosen per cache from its "
                   "distribution; caches predicted to gain less than --min-gain are not used) or a constant in [0, 1)");
    int guide_vertices = -1;
    app.add_option("--guide-vertices", guide_vertices,
                   "Guide only the first N non-specular vertices of each path (0 = all; default 1, and with --mode "
                   "auto the pilot also weighs every vertex with less Russian roulette)");
    app.add_option("--min-gain", guide_options.min_gain,
                   "With --bsdf-fraction auto: least predicted variance reduction for a cache to be used (>= 1)");
    std::string product = "on";
    app.add_option("--product", product,
                   "Where a cache guides a glossy lobe (rough conductor, Ward without a diffuse part): on (default) = "
                   "sample the map's product with the lobe | off = the map alone");
    std::string caustics;
    app.add_option("--caustics", caustics,
                   "Light-trace caustics seen directly by the camera (light -> specular chain -> visible surface), "
                   "taking them out of the path tracer's work: auto (default with --mode auto: where a pilot "
                   "predicts a gain at equal time, weighed with guiding) | on | off (default otherwise)");
    app.add_option("--light-paths", opt.light_paths_per_pixel,
                   "With --caustics: light paths per pixel and pass (default: 1 with on, the pilot's choice with auto)");
    std::string connect;
    app.add_option("--connect", connect,
                   "Caustic connections: every non-specular vertex of a camera path also joins a light path's vertex "
                   "behind a specular chain (light reflected off a caustic), weighed against the path tracer by MIS: "
                   "auto (default with --mode auto: where its pilot predicts a gain, with the caustics light-traced) | "
                   "on | off (default otherwise)");
    std::string sampler = "sobol";
    app.add_option("--sampler", sampler,
                   "Random numbers of a pixel's samples: sobol (default: the pixel position and the first bounce's "
                   "direction and light samples are stratified across the pixel's samples, Owen-scrambled Sobol) | "
                   "independent (every sample's own random numbers)");
    app.add_option("--snapshot", opt.snapshot_interval,
                   "Every SECONDS, write the image so far to the output (atomically), so that an interrupted "
                   "render still leaves a usable image");
    bool learn = false;
    std::string write_atlas;
    app.add_flag("--learn", learn,
                 "With --atlas: hybrid caches -- the caches' maps are refit from their photons plus the radiance the "
                 "render's paths receive, after 1, 2, 4, 8, ... samples per pixel");
    app.add_option("--write-atlas", write_atlas,
                   "With --learn: write the refit cache atlas (photons + path samples; the maps the last pass sampled) to "
                   "this HDF5 file, for reuse as --atlas");
    std::string sample_range;
    app.add_option("--sample-range", sample_range,
                   "A:B -- render only samples A..B-1 of each pixel (of the --spp in all), seeded as in one run, and "
                   "store the film's sums so that `merge-images` adds the parts into the image of one run; needs a "
                   "fixed --spp and --mode (not --time, not --mode auto or --caustics auto)");
    app.add_flag("-q,--quiet", opt.quiet, "No progress output");
    bool no_scene_warnings = false;
    iris::add_scene_options(app, &defines, &no_scene_warnings);
    if (int rc = iris::parse_command_line(app, argc, argv, "render"); rc >= 0) return rc;
    try {
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
        opt.auto_guide = mode == "auto";
        opt.mode = opt.auto_guide ? iris::GuideMode::NeeBsdfCache : iris::parse_guide_mode(mode);
        if (caustics.empty()) caustics = opt.auto_guide ? "auto" : "off";
        if (caustics == "auto") opt.caustics = iris::RenderOptions::Caustics::Auto;
        else if (caustics == "on") opt.caustics = iris::RenderOptions::Caustics::On;
        else if (caustics == "off") opt.caustics = iris::RenderOptions::Caustics::Off;
        else throw std::runtime_error("--caustics must be auto, on or off, got '" + caustics + "'");
        if (app.count("--light-paths") && !(opt.light_paths_per_pixel > 0 && opt.light_paths_per_pixel <= 1024))
            throw std::runtime_error("--light-paths must be in (0, 1024]");
        if (opt.auto_guide && atlas_path.empty()) throw std::runtime_error("--mode auto needs --atlas");
        if (learn && atlas_path.empty()) throw std::runtime_error("--learn needs --atlas");
        if (learn && opt.mode == iris::GuideMode::NeeBsdf) throw std::runtime_error("--learn needs a guided --mode");
        if (!write_atlas.empty() && !learn) throw std::runtime_error("--write-atlas needs --learn");
        if (!write_atlas.empty()) iris::check_output_path(write_atlas);
        guide_options.learn = learn;
        if (product != "on" && product != "off") throw std::runtime_error("--product must be on or off, got '" + product + "'");
        guide_options.product = product == "on";
        if (connect.empty()) connect = opt.auto_guide ? "auto" : "off";
        if (connect == "auto") opt.connect = iris::RenderOptions::Connect::Auto;
        else if (connect == "on") opt.connect = iris::RenderOptions::Connect::On;
        else if (connect == "off") opt.connect = iris::RenderOptions::Connect::Off;
        else throw std::runtime_error("--connect must be auto, on or off, got '" + connect + "'");
        if (sampler == "sobol") opt.sampler = iris::RenderOptions::Sampler::Sobol;
        else if (sampler == "independent") opt.sampler = iris::RenderOptions::Sampler::Independent;
        else throw std::runtime_error("--sampler must be sobol or independent, got '" + sampler + "'");
        if (bsdf_fraction != "auto") {
            guide_options.bsdf_fraction = iris::parse_float_option("--bsdf-fraction", bsdf_fraction);
            if (!(guide_options.bsdf_fraction >= 0 && guide_options.bsdf_fraction < 1))
                throw std::runtime_error("--bsdf-fraction must be auto or in [0, 1), got " + bsdf_fraction);
        }
        if (!(guide_options.min_gain >= 1 && std::isfinite(guide_options.min_gain)))
            throw std::runtime_error("--min-gain must be >= 1");
        if (app.count("--rr-depth") && opt.rr_depth < 1 && opt.rr_depth != -1)
            throw std::runtime_error("--rr-depth must be >= 1, or -1 for no Russian roulette");
        if (app.count("--rr-threshold") && !(opt.rr_threshold > 0 && opt.rr_threshold <= 1))
            throw std::runtime_error("--rr-threshold must be in (0, 1]");
        if (app.count("--guide-vertices")) {
            if (guide_vertices < 0) throw std::runtime_error("--guide-vertices must be >= 0 (0 = every vertex)");
            opt.guide_vertices = guide_vertices;
        }
        if (opt.threads < 0) throw std::runtime_error("--threads must be positive");
        // The thread limit covers loading too: the atlas is decompressed and the guide built in parallel.
        const unsigned threads = opt.threads > 0 ? unsigned(opt.threads) : std::max(1u, std::thread::hardware_concurrency());
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
        iris::SceneLoadOptions lo;
        lo.parameters = iris::parse_defines(defines);
        lo.quiet_warnings = no_scene_warnings;
        opt.command_line = iris::join_args(argc, argv);
        iris::Scene scene = iris::load_scene(scene_path, lo);
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
        } else if (atlas_path.empty() && (opt.mode == iris::GuideMode::NeeCache)) {
            throw std::runtime_error("--mode nee+cache needs --atlas");
        }
        if (opt.snapshot_interval > 0) opt.snapshot = [&](const iris::Image& img) { iris::write_exr(output, img); };
        iris::RenderStats stats;
        iris::Image img = iris::render_image(scene, opt, &stats);
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
