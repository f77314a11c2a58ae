#include "formats/png.h"

#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "formats/exr.h"

namespace iris {

void write_png(const std::string& path, int width, int height, const std::vector<float>& rgb01) {
    if (rgb01.size() != size_t(width) * height * 3) throw ImageError(path + ": internal error: image size mismatch");
    std::string tmp = path + ".tmp-" + std::to_string(getpid());
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw ImageError(path + ": cannot open for writing");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    std::vector<unsigned char> row(size_t(width) * 3);
    bool ok = png && info;
    if (ok && setjmp(png_jmpbuf(png))) ok = false;
    else if (ok) {
        png_init_io(png, f);
        png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_write_info(png, info);
        for (int y = 0; y < height; ++y) {
            for (int i = 0; i < width * 3; ++i) {
                float v = rgb01[size_t(y) * width * 3 + i];
                v = std::isfinite(v) ? std::fmin(1.0f, std::fmax(0.0f, v)) : 0.0f;
                row[i] = (unsigned char)std::lround(v * 255.0f);
            }
            png_write_row(png, row.data());
        }
        png_write_end(png, nullptr);
    }
    png_destroy_write_struct(&png, &info);
    ok = (std::fclose(f) == 0) && ok;
    if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
        std::remove(tmp.c_str());
        throw ImageError(path + ": cannot write PNG");
    }
}

}  // namespace iris
