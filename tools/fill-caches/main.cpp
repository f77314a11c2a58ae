// fill-caches: gather photons into each cache's directional map and store PDFs and CDFs (atlas.h5).
// A thin shell over tools/fill-caches/cache_filler.h.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/hdf5_util.h"
#include "formats/photon_map.h"
#include "tools/common/settings.h"
#include "tools/common/tool_util.h"
#include "tools/fill-caches/cache_filler.h"

int main(int argc, char** argv) {
    iris::FillOptions opt;
    std::string caches_path, photons_path, output;
    CLI::App app{"fill-caches: fill each cache's equal-area directional map from its nearest photons"};
    app.set_version_flag("--version", std::string("iris fill-caches ") + IRIS_VERSION);
    app.add_option("caches", caches_path, "Cache positions from place-caches")->required();
    app.add_option("--photon-map", photons_path, "Photon map from trace-photons")->required();
    app.add_option("-o,--output", output, "Cache atlas to write (.h5)")->required();
    std::vector<std::string> assignments;
    iris::add_settings_options(app, iris::kFillCaches, "fill-caches", &assignments);
    app.add_option("-t,--threads", opt.threads, "Worker threads (default: all cores)");
    uint64_t seed = 0;
    app.add_option("--seed", seed, "Accepted for uniformity with the other tools (filling is not random)");
    app.add_flag("-q,--quiet", opt.quiet, "No progress output");
    if (int rc = iris::parse_command_line(app, argc, argv, "fill-caches"); rc >= 0) return rc;
    try {
        iris::Settings settings(iris::kFillCaches, "fill-caches");
        settings.set_all(assignments);
        opt.k = uint32_t(settings.integer("gather-count"));
        opt.resolution = int(settings.integer("map-resolution"));
        opt.max_radius = settings.number("max-radius");
        opt.min_photons = uint32_t(settings.integer("min-photons"));
        opt.filter_sigma = settings.number("filter-sigma");
        opt.floor = settings.number("floor");
        opt.direct = settings.on("direct-photons");
        iris::check_fill_options(opt);
        if (opt.threads < 0) throw std::runtime_error("--threads must be >= 0 (0 = all cores)");
        iris::check_output_path(output);
        iris::CachePointsFile cf = iris::read_cache_points(caches_path);
        // The photons must come from the same scene as the caches. Without caches (place-caches skipped a
        // scene that guiding would not help) only that is checked: the photons themselves are not needed.
        iris::PhotonMapFile pf;
        if (cf.caches.size() == 0)
            pf.header = iris::read_photon_map_header(photons_path, cf.header.scene_fingerprint);
        else
            pf = iris::read_photon_map(photons_path, cf.header.scene_fingerprint);
        // The scene's extent, from the cache positions and photons (the scene file is not an input here).
        iris::Vec3 lo(iris::kInf), hi(-iris::kInf);
        for (iris::Vec3 p : pf.photons.position) {
            lo = iris::vmin(lo, p);
            hi = iris::vmax(hi, p);
        }
        for (iris::Vec3 p : cf.caches.position) {
            lo = iris::vmin(lo, p);
            hi = iris::vmax(hi, p);
        }
        double diagonal = (cf.caches.size() + pf.photons.size()) ? iris::length(hi - lo) : 1.0;
        iris::FillStats stats;
        iris::CacheAtlas atlas = iris::fill_caches(cf.caches, pf.photons, diagonal, opt, &stats);
        iris::Provenance prov;
        prov.tool = "fill-caches";
        prov.tool_version = IRIS_VERSION;
        prov.command_line = iris::join_args(argc, argv);
        prov.inputs = caches_path + " " + iris::file_fingerprint(caches_path) + "\n" + photons_path + " " +
                      iris::file_fingerprint(photons_path);
        prov.seed = seed;
        prov.parameters = {{"k", double(opt.k)},
                           {"resolution", double(opt.resolution)},
                           {"max_radius", opt.max_radius},
                           {"min_photons", double(opt.min_photons)},
                           {"filter_sigma", opt.filter_sigma},
                           {"floor", opt.floor},
                           {"direct", opt.direct ? 1.0 : 0.0},
                           {"usable", double(stats.usable)},
                           {"mean_photons", stats.mean_photons},
                           {"seconds", stats.seconds}};
        settings.add_to_parameters(&prov.parameters);
        iris::write_cache_atlas(output, atlas, cf.header.scene_fingerprint, prov);
        if (!opt.quiet)
            std::fprintf(stderr,
                         "fill-caches: wrote %s (%u usable + %u unusable caches, %.0f photons and radius %.4g on "
                         "average, %.1f MB of maps, %.2f s)\n",
                         output.c_str(), stats.usable, stats.unusable, stats.mean_photons, stats.mean_radius,
                         double(atlas.pdf.size() + atlas.cdf.size()) * 4e-6, stats.seconds);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "fill-caches: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
