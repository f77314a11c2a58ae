// merge-photons: join the parts of a photon map (trace-photons --path-range A:B) into the map of one
// run. A thin shell over tools/merge/merge.h.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "tools/common/tool_util.h"
#include "tools/merge/merge.h"

int main(int argc, char** argv) {
    std::vector<std::string> parts;
    std::string output;
    bool quiet = false;
    CLI::App app{"merge-photons: join the parts of a photon map (trace-photons --path-range A:B, together covering "
                 "0:paths) into the map one run of all paths writes"};
    app.set_version_flag("--version", std::string("iris merge-photons ") + IRIS_VERSION);
    app.add_option("parts", parts, "Partial photon maps (.h5), in any order")->required();
    app.add_option("-o,--output", output, "Merged photon map (.h5)")->required();
    app.add_flag("-q,--quiet", quiet, "No report on stderr");
    if (int rc = iris::parse_command_line(app, argc, argv, "merge-photons"); rc >= 0) return rc;
    try {
        iris::check_output_path(output);
        iris::MergedPhotons m = iris::merge_photon_parts(parts, iris::join_args(argc, argv));
        iris::write_photon_map(output, m.photons, m.scene_fingerprint, m.provenance);
        if (!quiet)
            std::fprintf(stderr, "merge-photons: wrote %s (%zu photons from %llu paths in %zu parts)\n", output.c_str(),
                         m.photons.size(), (unsigned long long)m.photons.emitted_paths, parts.size());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "merge-photons: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
