// trace-photons: emit photons from the lights and store them at every non-specular hit (photons.h5).
// A thin shell over tools/trace-photons/photon_tracer.h.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "formats/hdf5_util.h"
#include "formats/photon_map.h"
#include "formats/scene_xml.h"
#include "tools/common/settings.h"
#include "tools/common/tool_util.h"
#include "tools/trace-photons/photon_tracer.h"

int main(int argc, char** argv) {
    iris::PhotonOptions opt;
    std::string scene_path, output;
    std::vector<std::string> defines;
    CLI::App app{"trace-photons: trace photon paths from the lights of a scene into a photon map (HDF5)"};
    app.set_version_flag("--version", std::string("iris trace-photons ") + IRIS_VERSION);
    app.add_option("scene", scene_path, "Scene file (Mitsuba 0.5 XML)")->required();
    app.add_option("-o,--output", output, "Photon map to write (.h5)")->required();
    std::vector<std::string> assignments;
    iris::add_settings_options(app, iris::kTracePhotons, "trace-photons", &assignments);
    app.add_option("-t,--threads", opt.threads, "Worker threads (default: all cores)");
    app.add_option("--seed", opt.seed, "Random seed (same seed => same file, for any thread count)");
    std::string path_range;
    app.add_option("--path-range", path_range,
                   "A:B -- trace only paths A..B-1 of the photon-paths in all (flux normalised by the total), seeded as in "
                   "one run; `merge-photons` joins the parts into the map of one run");
    app.add_flag("-q,--quiet", opt.quiet, "No progress output");
    bool no_scene_warnings = false, strict = false;
    iris::add_scene_options(app, &defines, &no_scene_warnings, &strict);
    if (int rc = iris::parse_command_line(app, argc, argv, "trace-photons"); rc >= 0) return rc;
    try {
        iris::Settings settings(iris::kTracePhotons, "trace-photons");
        settings.set_all(assignments);
        const long long photons = settings.integer("photon-count");
        const bool by_photons = settings.integer("photon-paths") == 0;
        opt.paths = by_photons ? opt.paths : uint64_t(settings.integer("photon-paths"));
        opt.max_depth = int(settings.integer("photon-depth"));
        opt.rr_depth = int(settings.integer("photon-rr-depth"));
        opt.cutoff = float(settings.number("photon-cutoff"));
        const double min_caustic_share = settings.number("min-caustic-share");
        if (by_photons && !path_range.empty())
            throw std::runtime_error("--path-range needs the setting photon-paths (the parts must agree on the paths in all)");
        if (!path_range.empty()) {
            uint64_t a = 0, b = 0;
            if (!iris::parse_range(path_range, &a, &b))
                throw std::runtime_error("--path-range must be A:B with 0 <= A < B, got '" + path_range + "'");
            if (b > opt.paths)
                throw std::runtime_error("--path-range " + path_range + " is not within the " + std::to_string(opt.paths) +
                                         " paths (photon-paths)");
            opt.path_begin = a;
            opt.path_end = b;
        }
        if (opt.threads < 0) throw std::runtime_error("--threads must be >= 0 (0 = all cores)");
        iris::check_output_path(output);
        iris::SceneLoadOptions lo;
        lo.parameters = iris::parse_defines(defines);
        lo.quiet_warnings = no_scene_warnings;
        lo.strict = strict;
        lo.spectrum_interpolation = settings.is("spectrum-interpolation", "linear")
                                        ? iris::SpectrumInterpolation::Linear
                                        : iris::SpectrumInterpolation::Mitsuba050;
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
        // The settings as they ran (merge-photons compares them between parts by name).
        settings.add_to_parameters(&prov.parameters);
        if (opt.path_end > 0) {
            // A part: its range and the total it is a part of (merge-photons checks they tile 0:total).
            prov.parameters["path_begin"] = double(opt.path_begin);
            prov.parameters["path_end"] = double(opt.path_end);
            prov.parameters["path_total"] = double(total_paths);
        }
        iris::write_photon_map(output, map, scene.fingerprint, prov);
        if (skip)  // a decision, reported even with -q (as place-caches reports its own)
            std::fprintf(stderr, "trace-photons: no surface of %s has a specular (Dirac) lobe, so no light arrives "
                         "through specular chains and place-caches skips guiding (min-caustic-share=%g); "
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
