// trace-photons: emit photons from the lights and store them at every non-specular hit (photons.h5).
// A thin shell over tools/trace-photons/photon_tracer.h.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "formats/hdf5_util.h"
#include "formats/photon_map.h"
#include "formats/scene_xml.h"
#include "libcommon/tool_util.h"
#include "tools/trace-photons/photon_tracer.h"

int main(int argc, char** argv) {
    iris::PhotonOptions opt;
    std::string scene_path, output;
    std::vector<std::string> defines;
    CLI::App app{"trace-photons: trace photon paths from the lights of a scene into a photon map (HDF5)"};
    app.set_version_flag("--version", std::string("iris trace-photons ") + IRIS_VERSION);
    app.add_option("scene", scene_path, "Scene file (Mitsuba 0.5 XML)")->required();
    app.add_option("-o,--output", output, "Photon map to write (.h5)")->required();
    // Read as a signed number: CLI11 converts "-5" into a uint64_t by wrapping it around (to 2^64 - 5),
    // which then overflowed the chunk count and produced an empty photon map with exit status 0.
    long long paths = (long long)opt.paths;
    app.add_option("--paths", paths, "Photon paths to emit (default 250000)");
    long long photons = 0;
    app.add_option("--photons", photons,
                   "Instead of --paths: emit as many paths as store about this many photons (photons per path "
                   "measured on the first 32768 paths; at most 2^26 paths)");
    app.add_option("--max-depth", opt.max_depth, "Longest photon path in segments, -1 = unlimited");
    app.add_option("--rr-depth", opt.rr_depth, "Russian roulette from this many bounces on");
    app.add_option("--cutoff", opt.cutoff, "Stop a path below this fraction of its emitted power");
    app.add_option("-t,--threads", opt.threads, "Worker threads (default: all cores)");
    app.add_option("--seed", opt.seed, "Random seed (same seed => same file, for any thread count)");
    double min_caustic_share = 0;
    app.add_option("--min-caustic-share", min_caustic_share,
                   "place-caches' threshold (the pipeline passes the same): when it is > 0 and no surface of the "
                   "scene has a specular (Dirac) lobe, the share is 0 whatever the photons, so none is traced "
                   "and the photon map is empty");
    std::string path_range;
    app.add_option("--path-range", path_range,
                   "A:B -- trace only paths A..B-1 of the --paths in all (flux normalised by the total), seeded as in "
                   "one run; `merge-photons` joins the parts into the map of one run");
    app.add_flag("-q,--quiet", opt.quiet, "No progress output");
    bool no_scene_warnings = false;
    iris::add_scene_options(app, &defines, &no_scene_warnings);
    if (int rc = iris::parse_command_line(app, argc, argv, "trace-photons"); rc >= 0) return rc;
    try {
        if (paths <= 0) throw std::runtime_error("--paths must be positive, got " + std::to_string(paths));
        opt.paths = uint64_t(paths);
        const bool by_photons = app.count("--photons") > 0;
        if (by_photons && app.count("--paths"))
            throw std::runtime_error("give --paths or --photons, not both");
        if (by_photons && photons <= 0)
            throw std::runtime_error("--photons must be positive, got " + std::to_string(photons));
        if (by_photons && !path_range.empty())
            throw std::runtime_error("--path-range needs --paths (the parts must agree on the paths in all)");
        if (!path_range.empty()) {
            uint64_t a = 0, b = 0;
            if (!iris::parse_range(path_range, &a, &b))
                throw std::runtime_error("--path-range must be A:B with 0 <= A < B, got '" + path_range + "'");
            if (b > opt.paths)
                throw std::runtime_error("--path-range " + path_range + " is not within the " + std::to_string(opt.paths) +
                                         " paths (--paths)");
            opt.path_begin = a;
            opt.path_end = b;
        }
        if (opt.threads < 0) throw std::runtime_error("--threads must be >= 0 (0 = all cores)");
        if (!(min_caustic_share >= 0 && min_caustic_share <= 1))
            throw std::runtime_error("--min-caustic-share must be in [0, 1]");
        iris::check_output_path(output);
        iris::SceneLoadOptions lo;
        lo.parameters = iris::parse_defines(defines);
        lo.quiet_warnings = no_scene_warnings;
        iris::Scene scene = iris::load_scene(scene_path, lo);
        iris::PhotonStats stats;
        // A scene without caustics skips guiding (place-caches); tracing its photons would only cost time.
        const bool skip = min_caustic_share > 0 && !iris::has_specular_surfaces(scene);
        if (by_photons && !skip) opt.paths = iris::paths_for_photons(scene, opt, uint64_t(photons));
        iris::PhotonMap map = skip ? iris::PhotonMap{} : iris::trace_photons(scene, opt, &stats);
        const uint64_t total_paths = opt.paths;
        if (skip) opt.paths = 0;
        iris::Provenance prov;
        prov.tool = "trace-photons";
        prov.tool_version = IRIS_VERSION;
        prov.command_line = iris::join_args(argc, argv);
        prov.inputs = scene_path + " " + scene.fingerprint;
        prov.seed = opt.seed;
        prov.parameters = {{"paths", double(opt.paths)},     {"max_depth", double(opt.max_depth)},
                           {"rr_depth", double(opt.rr_depth)}, {"cutoff", double(opt.cutoff)},
                           {"seconds", stats.seconds},       {"nonfinite_discarded", double(stats.nonfinite)},
                           // So that place-caches can decide to skip a scene from the header alone.
                           {"caustic_share", iris::caustic_power_share(map)},
                           {"min_caustic_share", min_caustic_share}};
        if (by_photons) prov.parameters["photons_target"] = double(photons);
        if (opt.path_end > 0) {
            // A part: its range and the total it is a part of (merge-photons checks they tile 0:total).
            prov.parameters["path_begin"] = double(opt.path_begin);
            prov.parameters["path_end"] = double(opt.path_end);
            prov.parameters["path_total"] = double(total_paths);
        }
        iris::write_photon_map(output, map, scene.fingerprint, prov);
        if (skip)  // a decision, reported even with -q (as place-caches reports its own)
            std::fprintf(stderr, "trace-photons: no surface of %s has a specular (Dirac) lobe, so no light arrives "
                         "through specular chains and place-caches skips guiding (--min-caustic-share %g); "
                         "wrote an empty photon map %s\n", scene_path.c_str(), min_caustic_share, output.c_str());
        else if (!opt.quiet)
            std::fprintf(stderr, "trace-photons: wrote %s (%zu photons from %llu paths, %.2f per path, %.2f s%s)\n",
                         output.c_str(), map.size(), (unsigned long long)opt.paths, double(map.size()) / opt.paths,
                         stats.seconds,
                         stats.nonfinite ? (", " + std::to_string(stats.nonfinite) + " NaN/Inf discarded").c_str() : "");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "trace-photons: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
