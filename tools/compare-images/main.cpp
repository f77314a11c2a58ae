// compare-images: error metrics of a rendered image against a reference (EXR or 8-bit sRGB PNG),
// an optional false-colour error image, and thresholds that turn the result into an exit code
// (0 = within thresholds, 2 = a threshold exceeded, 1 = error), for tests, pipelines and benchmarks.
#include <CLI/CLI.hpp>

#include "tools/common/tool_util.h"

#include <cstdio>
#include <string>

#include "formats/exr.h"
#include "formats/png.h"
#include "libcommon/image_metrics.h"
#include "libcommon/spectrum.h"

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Three channels of an image interleaved (3 floats per pixel); empty if any is missing.
std::vector<float> interleave(const iris::Image& img, const char* r_name, const char* g_name, const char* b_name) {
    int r = img.channel_index(r_name), g = img.channel_index(g_name), b = img.channel_index(b_name);
    if (r < 0 || g < 0 || b < 0) return {};
    std::vector<float> out(size_t(img.width) * img.height * 3);
    for (size_t i = 0; i < size_t(img.width) * img.height; ++i) {
        out[3 * i] = img.data[r][i];
        out[3 * i + 1] = img.data[g][i];
        out[3 * i + 2] = img.data[b][i];
    }
    return out;
}

// RGB data (3 floats per pixel) of an EXR or PNG; *srgb8 tells whether the values are display-encoded.
// `variance`, if given, receives the layers variance.R/G/B where the image has them (render --variance).
std::vector<float> load_rgb(const std::string& path, int* w, int* h, bool* srgb8, std::vector<float>* variance = nullptr) {
    iris::Image img = ends_with(path, ".png") ? iris::read_png(path) : iris::read_exr(path);
    *srgb8 = ends_with(path, ".png");
    std::vector<float> out = interleave(img, "R", "G", "B");
    if (out.empty()) throw iris::ImageError(path + ": no R, G, B channels");
    *w = img.width;
    *h = img.height;
    if (variance) *variance = interleave(img, "variance.R", "variance.G", "variance.B");
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    std::string test_path, ref_path, error_image;
    std::vector<std::string> masks;
    bool mitsuba_banner = false, json = false;
    double error_scale = 1.0, max_rel_mse = -1, max_mean_diff = -1;
    CLI::App app{"compare-images: relMSE, trimmed relMSE, MAPE and channel means of TEST against REFERENCE"};
    app.set_version_flag("--version", std::string("iris compare-images ") + IRIS_VERSION);
    app.add_option("test", test_path, "Image to judge (.exr, or .png = 8-bit sRGB)")->required();
    app.add_option("reference", ref_path, "Reference image (.exr, or .png = 8-bit sRGB)");
    bool metadata = false;
    std::string srgb_png;
    app.add_option("--srgb-png", srgb_png, "Also write TEST as an 8-bit sRGB PNG (exposure 0, clipped)");
    std::string crop;
    app.add_option("--crop", crop, "With --srgb-png: write only the pixel rectangle x0,y0,x1,y1 (half-open)");
    app.add_flag("--metadata", metadata, "Only print TEST's metadata (EXR string attributes), one 'key value' per line");
    app.add_option("--mask", masks, "Leave out the pixel rectangle x0,y0,x1,y1 (half-open); repeatable");
    app.add_flag("--mitsuba-banner", mitsuba_banner, "Leave out Mitsuba's banner (rows >= H-12, columns 650-765)");
    app.add_option("-o,--error-image", error_image, "Write a false-colour relative-error PNG here");
    app.add_option("--error-scale", error_scale, "Relative squared error shown as full red (default 1)");
    app.add_option("--max-relmse", max_rel_mse, "Exit 2 if relMSE exceeds this");
    app.add_option("--max-mean-diff", max_mean_diff,
                   "Exit 2 if a channel's mean after sRGB 8-bit encoding differs by more than this percentage");
    app.add_flag("--json", json, "Print the metrics as one JSON object");
    if (int rc = iris::parse_command_line(app, argc, argv, "compare-images"); rc >= 0) return rc;
    try {
        // Outputs are checked before any work, so a bad path costs nothing and prints only its error.
        if (!srgb_png.empty()) iris::check_output_path(srgb_png);
        if (!error_image.empty()) iris::check_output_path(error_image);
        if (metadata) {
            iris::Image img = iris::read_exr(test_path);
            for (const auto& [k, v] : img.metadata) std::printf("%s %s\n", k.c_str(), v.c_str());
            return 0;
        }
        if (!srgb_png.empty()) {
            int w, h;
            bool is8;
            std::vector<float> rgb = load_rgb(test_path, &w, &h, &is8);
            if (!is8)
                for (float& v : rgb) v = iris::to_srgb8(v) / 255.0f;
            if (!crop.empty()) {
                int x0, y0, x1, y1;
                char tail = 0;
                if (std::sscanf(crop.c_str(), "%d,%d,%d,%d%c", &x0, &y0, &x1, &y1, &tail) != 4 || x0 < 0 || y0 < 0 ||
                    x1 <= x0 || y1 <= y0 || x1 > w || y1 > h)
                    throw std::runtime_error("--crop must be x0,y0,x1,y1 inside the " + std::to_string(w) + "x" +
                                             std::to_string(h) + " image, got \"" + crop + "\"");
                std::vector<float> part;
                part.reserve(size_t(x1 - x0) * size_t(y1 - y0) * 3);
                for (int y = y0; y < y1; ++y)
                    part.insert(part.end(), rgb.begin() + (size_t(y) * w + x0) * 3, rgb.begin() + (size_t(y) * w + x1) * 3);
                rgb = std::move(part);
                w = x1 - x0;
                h = y1 - y0;
            }
            iris::write_png(srgb_png, w, h, rgb);
            if (ref_path.empty()) return 0;
        }
        if (ref_path.empty()) throw std::runtime_error("a reference image is required");
        int wt, ht, wr, hr;
        bool t8, r8;
        std::vector<float> test = load_rgb(test_path, &wt, &ht, &t8);
        std::vector<float> ref_variance;
        std::vector<float> ref = load_rgb(ref_path, &wr, &hr, &r8, &ref_variance);
        if (wt != wr || ht != hr)
            throw std::runtime_error(test_path + ": size " + std::to_string(wt) + "x" + std::to_string(ht) +
                                     " differs from the reference's " + std::to_string(wr) + "x" + std::to_string(hr));
        if (t8)
            for (float& v : test) v = iris::srgb_to_linear(v);
        std::vector<iris::PixelRect> rects;
        for (const std::string& m : masks) {
            iris::PixelRect r;
            if (std::sscanf(m.c_str(), "%d,%d,%d,%d", &r.x0, &r.y0, &r.x1, &r.y1) != 4)
                throw std::runtime_error("--mask expects x0,y0,x1,y1, got \"" + m + "\"");
            rects.push_back(r);
        }
        if (mitsuba_banner) rects.push_back({650, hr - 12, 766, hr});
        iris::ImageMetrics m = iris::compare_images(test, ref, wt, ht, rects, r8, ref_variance);
        double worst_mean_diff = 0;
        for (int c = 0; c < 3; ++c) {
            double d = m.mean_ref_srgb8[c] > 0
                           ? 100.0 * std::abs(m.mean_test_srgb8[c] - m.mean_ref_srgb8[c]) / m.mean_ref_srgb8[c]
                           : 0.0;
            worst_mean_diff = std::max(worst_mean_diff, d);
        }
        // The reference's own expected share of relMSE, where it carries variance layers (null otherwise).
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.6g", m.rel_mse_reference_noise);
        const std::string ref_noise = m.rel_mse_reference_noise >= 0 ? buf : "null";
        if (json) {
            std::printf("{\"relmse\": %.6g, \"relmse_trimmed\": %.6g, \"mape\": %.6g, \"mse\": %.6g, "
                        "\"mean_test\": [%.6g, %.6g, %.6g], \"mean_ref\": [%.6g, %.6g, %.6g], "
                        "\"mean_test_srgb8\": [%.4f, %.4f, %.4f], \"mean_ref_srgb8\": [%.4f, %.4f, %.4f], "
                        "\"worst_mean_diff_percent\": %.4f, \"pixels\": %llu, \"relmse_reference_noise\": %s}\n",
                        m.rel_mse, m.rel_mse_trimmed, m.mape, m.mse, m.mean_test.r, m.mean_test.g, m.mean_test.b,
                        m.mean_ref.r, m.mean_ref.g, m.mean_ref.b, m.mean_test_srgb8.r, m.mean_test_srgb8.g,
                        m.mean_test_srgb8.b, m.mean_ref_srgb8.r, m.mean_ref_srgb8.g, m.mean_ref_srgb8.b,
                        worst_mean_diff, (unsigned long long)m.pixels, ref_noise.c_str());
        } else {
            std::printf("relMSE            %.6g\nrelMSE (trimmed)  %.6g\nMAPE              %.6g\n", m.rel_mse,
                        m.rel_mse_trimmed, m.mape);
            if (m.rel_mse_reference_noise >= 0)
                std::printf("reference noise   %.6g of the relMSE (its variance layers): %.6g without it\n",
                            m.rel_mse_reference_noise, m.rel_mse - m.rel_mse_reference_noise);
            std::printf("mean linear       test (%.5g, %.5g, %.5g)  reference (%.5g, %.5g, %.5g)\n", m.mean_test.r,
                        m.mean_test.g, m.mean_test.b, m.mean_ref.r, m.mean_ref.g, m.mean_ref.b);
            std::printf("mean sRGB 8-bit   test (%.3f, %.3f, %.3f)  reference (%.3f, %.3f, %.3f)  worst %.3f %%\n",
                        m.mean_test_srgb8.r, m.mean_test_srgb8.g, m.mean_test_srgb8.b, m.mean_ref_srgb8.r,
                        m.mean_ref_srgb8.g, m.mean_ref_srgb8.b, worst_mean_diff);
        }
        if (!error_image.empty())
            iris::write_png(error_image, wt, ht, iris::error_false_colour(test, ref, wt, ht, error_scale, r8));
        bool fail = (max_rel_mse >= 0 && m.rel_mse > max_rel_mse) || (max_mean_diff >= 0 && worst_mean_diff > max_mean_diff);
        if (fail) {
            std::fprintf(stderr, "compare-images: %s exceeds the thresholds against %s\n", test_path.c_str(),
                         ref_path.c_str());
            return 2;
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "compare-images: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
