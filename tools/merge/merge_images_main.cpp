// merge-images: join the parts of a render (render --sample-range A:B) into the image of one run.
// A thin shell over tools/merge/merge.h.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "tools/common/tool_util.h"
#include "tools/merge/merge.h"

int main(int argc, char** argv) {
    std::vector<std::string> parts;
    std::string output;
    bool quiet = false;
    CLI::App app{"merge-images: add the parts of a render (render --sample-range A:B, together covering 0:spp) "
                 "into the image one run of all samples writes"};
    app.set_version_flag("--version", std::string("iris merge-images ") + IRIS_VERSION);
    app.add_option("parts", parts, "Partial renders (.exr), in any order")->required();
    app.add_option("-o,--output", output, "Merged image (.exr)")->required();
    app.add_flag("-q,--quiet", quiet, "No report on stderr");
    if (int rc = iris::parse_command_line(app, argc, argv, "merge-images"); rc >= 0) return rc;
    try {
        iris::check_output_path(output);
        iris::Image img = iris::merge_image_parts(parts, iris::join_args(argc, argv));
        iris::write_exr(output, img);
        if (!quiet)
            std::fprintf(stderr, "merge-images: wrote %s (%dx%d, %s spp from %zu parts)\n", output.c_str(), img.width,
                         img.height, img.metadata["iris:spp"].c_str(), parts.size());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "merge-images: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
