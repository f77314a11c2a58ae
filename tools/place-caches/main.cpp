// place-caches: choose where the radiance caches go (caches.h5): camera blocks plus positions spread
// over the photon map. A thin shell over tools/place-caches/cache_placer.h.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "formats/cache_points.h"
#include "formats/hdf5_util.h"
#include "formats/photon_map.h"
#include "formats/scene_xml.h"
#include "tools/common/settings.h"
#include "tools/common/tool_util.h"
#include "tools/place-caches/cache_placer.h"

int main(int argc, char** argv) {
    iris::PlacementOptions opt;
    std::string scene_path, photons_path, output, resolution;
    std::vector<std::string> defines;
    CLI::App app{"place-caches: place radiance caches at camera-visible surfaces and over the photon map"};
    app.set_version_flag("--version", std::string("iris place-caches ") + IRIS_VERSION);
    app.add_option("scene", scene_path, "Scene file (Mitsuba 0.5 XML)")->required();
    app.add_option("--photon-map", photons_path, "Photon map from trace-photons")->required();
    app.add_option("-o,--output", output, "Cache positions to write (.h5)")->required();
    std::vector<std::string> assignments;
    iris::add_settings_options(app, iris::kPlaceCaches, "place-caches", &assignments);
    app.add_option("--resolution", resolution, "Image size WxH the blocks refer to (default: the scene's film)");
    app.add_option("-t,--threads", opt.threads, "Worker threads (default: all cores)");
    app.add_option("--seed", opt.seed, "Random seed");
    app.add_flag("-q,--quiet", opt.quiet, "No progress output");
    bool no_scene_warnings = false, strict = false;
    iris::add_scene_options(app, &defines, &no_scene_warnings, &strict);
    if (int rc = iris::parse_command_line(app, argc, argv, "place-caches"); rc >= 0) return rc;
    try {
        if (!resolution.empty()) iris::parse_resolution(resolution, &opt.width, &opt.height);
        iris::Settings settings(iris::kPlaceCaches, "place-caches");
        settings.set_all(assignments);
        opt.count = uint32_t(settings.integer("cache-count"));
        opt.camera_stride = int(settings.integer("camera-stride"));
        opt.reach_paths = int(settings.integer("reach-paths"));
        const double min_caustic_share = settings.number("min-caustic-share");
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
        iris::PlacementStats stats;
        // Skipping what the scene does not need: without light through specular chains, every path the
        // light takes can be connected by next-event estimation at each diffuse or glossy vertex, and
        // on the seed scenes guiding then did not pay for its preprocessing (docs/BENCHMARKS.md).
        // trace-photons records the share in the file's parameters; from older files it is computed.
        iris::PhotonMapFile pf;
        pf.header = iris::read_photon_map_header(photons_path, scene.fingerprint);
        const auto recorded = pf.header.provenance.parameters.find("caustic_share");
        double caustic_share = recorded != pf.header.provenance.parameters.end() ? recorded->second : -1;
        bool skip = caustic_share >= 0 && caustic_share < min_caustic_share;
        if (!skip) {
            pf = iris::read_photon_map(photons_path, scene.fingerprint);
            caustic_share = iris::caustic_power_share(pf.photons);
            skip = caustic_share >= 0 && caustic_share < min_caustic_share;
        }
        iris::CachePoints caches = skip ? iris::CachePoints{} : iris::place_caches(scene, pf.photons, opt, &stats);
        iris::Provenance prov;
        prov.tool = "place-caches";
        prov.tool_version = IRIS_VERSION;
        prov.command_line = iris::join_args(argc, argv);
        prov.inputs = scene_path + " " + scene.fingerprint + "\n" + photons_path + " " + iris::file_fingerprint(photons_path);
        prov.seed = opt.seed;
        prov.parameters = {{"count", double(opt.count)},          {"camera_stride", double(opt.camera_stride)},
                           {"camera_caches", double(stats.camera)}, {"photon_caches", double(stats.photon)},
                           {"cell_size", stats.cell_size},          {"seconds", stats.seconds},
                           {"min_caustic_share", min_caustic_share}, {"caustic_share", caustic_share},
                           {"reach_paths", double(opt.reach_paths)}, {"eligible_photons", double(stats.eligible)}};
        settings.add_to_parameters(&prov.parameters);
        iris::write_cache_points(output, caches, scene.fingerprint, prov);
        if (skip)  // said even with -q: it decides what the render does
            std::fprintf(stderr,
                         "place-caches: no caches: %.2f %% of the photon power arrives through specular chains "
                         "(below min-caustic-share=%g), so the render stays unguided; wrote %s\n",
                         100 * caustic_share, min_caustic_share, output.c_str());
        else if (!opt.quiet)
            std::fprintf(stderr, "place-caches: wrote %s (%u camera + %u photon caches, %llu of %zu photons %s, %.2f s)\n",
                         output.c_str(), stats.camera, stats.photon, (unsigned long long)stats.eligible,
                         pf.photons.position.size(),
                         opt.reach_paths > 0 ? "on surfaces camera paths reach" : "candidates (reach-paths=0)",
                         stats.seconds);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "place-caches: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
