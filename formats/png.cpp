#include "formats/png.h"

#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "formats/atomic_file.h"
#include "formats/exr.h"

namespace iris {

namespace {

// Encodes 8-bit sRGB-ready RGB into `f`. libpng reports errors by longjmp, so this function holds no
// object that needs a destructor and nothing is modified between setjmp and a possible longjmp.
bool encode_png(FILE* f, int width, int height, const std::vector<float>& rgb01, std::vector<unsigned char>& row) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
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
    png_destroy_write_struct(&png, &info);
    return true;
}

}  // namespace

void write_png(const std::string& path, int width, int height, const std::vector<float>& rgb01) {
    if (width <= 0 || height <= 0 || rgb01.size() != size_t(width) * height * 3)
        throw ImageError(path + ": internal error: image size mismatch");
    try {
        AtomicFile file(path);
        // libpng writes through stdio: a duplicate of the descriptor, closed by fclose.
        const int fd = ::dup(file.fd());
        FILE* f = fd >= 0 ? ::fdopen(fd, "wb") : nullptr;
        if (!f) {
            if (fd >= 0) ::close(fd);
            throw ImageError(path + ": cannot open the temporary file for writing");
        }
        std::vector<unsigned char> row(size_t(width) * 3);
        const bool encoded = encode_png(f, width, height, rgb01, row);
        const bool closed = std::fclose(f) == 0;
        if (!encoded || !closed) throw ImageError(path + ": cannot write PNG");  // ~AtomicFile removes the temporary
        file.commit();
    } catch (const ImageError&) {
        throw;
    } catch (const std::exception& e) {
        throw ImageError(e.what());  // AtomicFile's messages start with the path
    }
}

}  // namespace iris
