// inspect-caches: what is in a stage file, and what a cache learnt. A thin shell over inspect.h.
//   inspect-caches photons.h5 | caches.h5 | atlas.h5          statistics of any stage file
//   inspect-caches atlas.h5 --cache 17 -o pdf.exr              one cache's density as an image
//   inspect-caches atlas.h5 --scene s.xml --pixel 200,150 -o pdf.png   the cache serving that pixel
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <string>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/exr.h"
#include "formats/photon_map.h"
#include "formats/png.h"
#include "formats/scene_xml.h"
#include "tools/common/tool_util.h"
#include "tools/inspect-caches/inspect.h"

int main(int argc, char** argv) {
    std::string path, output, scene_path, pixel, resolution, layout = "latlong";
    long long cache = -1;
    int size = 0;
    std::vector<std::string> defines;
    CLI::App app{"inspect-caches: statistics of iris stage files (photon map, cache points, atlas) and images of "
                 "cache PDFs"};
    app.set_version_flag("--version", std::string("iris inspect-caches ") + IRIS_VERSION);
    app.add_option("file", path, "A stage file: photons.h5, caches.h5 or atlas.h5")->required();
    app.add_option("--cache", cache, "Atlas only: describe cache N (and write its PDF with -o)");
    app.add_option("--pixel", pixel, "Atlas only: the cache serving pixel X,Y of --scene's camera");
    app.add_option("--scene", scene_path, "The scene the atlas was made for (with --pixel)");
    app.add_option("--resolution", resolution, "Image size WxH that --pixel refers to (default: the scene's film)");
    app.add_option("-D,--define", defines, "Scene parameter name=value (for $name in the scene file)");
    std::string interpolation = "linear";  // part of the scene's fingerprint where a tabulated spectrum is read
    iris::add_spectrum_interpolation_option(app, &interpolation);
    app.add_option("-o,--output", output,
                   "Write the cache's PDF as an image: .exr (density per steradian) or .png (grey, scaled to its "
                   "maximum)");
    app.add_option("--layout", layout, "latlong (theta from the normal down, phi across) or octahedral (the texels)");
    app.add_option("--size", size, "Image rows (latlong, default 128) or pixels per texel (octahedral, default 8)");
    if (int rc = iris::parse_command_line(app, argc, argv, "inspect-caches"); rc >= 0) return rc;
    try {
        if (!output.empty()) iris::check_output_path(output);
        if (layout != "latlong" && layout != "octahedral")
            throw std::runtime_error("--layout must be latlong or octahedral, got \"" + layout + "\"");
        const iris::PdfLayout lay = layout == "latlong" ? iris::PdfLayout::LatLong : iris::PdfLayout::Octahedral;
        if (size == 0) size = lay == iris::PdfLayout::LatLong ? 128 : 8;
        const bool wants_cache = cache >= 0 || !pixel.empty();
        if (!pixel.empty() && scene_path.empty()) throw std::runtime_error("--pixel needs --scene");
        if (!output.empty() && !wants_cache) throw std::runtime_error("-o needs --cache or --pixel");

        const std::string kind = iris::stage_file_format(path);
        if (kind == iris::kPhotonMapFormat || kind == iris::kCachePointsFormat) {
            if (wants_cache) throw std::runtime_error(path + ": --cache and --pixel need an atlas, this is " + kind);
            if (kind == iris::kPhotonMapFormat) {
                iris::PhotonMapFile f = iris::read_photon_map(path);
                std::printf("%s%s", iris::describe_header(f.header).c_str(), iris::describe_photon_map(f.photons).c_str());
            } else {
                iris::CachePointsFile f = iris::read_cache_points(path);
                std::printf("%s%s", iris::describe_header(f.header).c_str(), iris::describe_cache_points(f.caches).c_str());
            }
            return 0;
        }
        if (kind != iris::kCacheAtlasFormat) throw std::runtime_error(path + ": not an iris stage file (format \"" + kind + "\")");

        if (!wants_cache) {
            iris::CacheAtlasFile f = iris::read_cache_atlas(path);
            std::printf("%s%s", iris::describe_header(f.header).c_str(), iris::describe_cache_atlas(f.atlas).c_str());
            return 0;
        }
        std::string expected_fingerprint;
        iris::Scene scene;
        if (!scene_path.empty()) {
            iris::SceneLoadOptions lo;
            lo.parameters = iris::parse_defines(defines);
            lo.spectrum_interpolation = interpolation == "linear" ? iris::SpectrumInterpolation::Linear
                                                                  : iris::SpectrumInterpolation::Mitsuba050;
            scene = iris::load_scene(scene_path, lo);
            expected_fingerprint = scene.fingerprint;
        }
        iris::CacheAtlasFile f = iris::read_cache_atlas(path, expected_fingerprint);
        if (!pixel.empty()) {
            int x = 0, y = 0, w = scene.film.width, h = scene.film.height;
            if (std::sscanf(pixel.c_str(), "%d,%d", &x, &y) != 2)
                throw std::runtime_error("--pixel expects X,Y, got \"" + pixel + "\"");
            if (!resolution.empty()) iris::parse_resolution(resolution, &w, &h);
            std::string why;
            cache = iris::cache_for_pixel(scene, f.atlas, x, y, w, h, &why);
            if (cache < 0) throw std::runtime_error("pixel " + pixel + ": " + why);
        }
        std::printf("%s", iris::describe_cache(f.atlas, size_t(cache)).c_str());
        if (output.empty()) return 0;
        iris::Image img = iris::cache_pdf_image(f.atlas, size_t(cache), lay, size);
        const bool png = output.size() >= 4 && output.compare(output.size() - 4, 4, ".png") == 0;
        if (png) {
            const std::vector<float>& v = img.data[0];
            const float peak = std::max(1e-30f, *std::max_element(v.begin(), v.end()));
            std::vector<float> rgb(v.size() * 3);
            for (size_t i = 0; i < v.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = v[i] / peak;
            iris::write_png(output, img.width, img.height, rgb);
        } else {
            iris::write_exr(output, img);
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "inspect-caches: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
