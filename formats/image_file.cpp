// Image files as inputs: the format is recognised by its magic number and decoded by its library.
// libpng and libjpeg report errors through longjmp; as in exr.cpp, every setjmp lives in a small
// function that owns no C++ objects with destructors, so the jump never skips one.
#include "formats/image_file.h"

#include <jpeglib.h>
#include <png.h>
#include <stb_image.h>

#include <csetjmp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

namespace iris {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    std::string s = path + ": " + what;
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    throw ImageError(s);
}

// Larger images than this (pixels) are refused before allocating: 2^28 pixels of 4 floats is 4 GiB.
constexpr unsigned long long kMaxPixels = 1ull << 28;

// ---- PNG (libpng) -------------------------------------------------------------------------------

struct PngIn {
    FILE* file = nullptr;
    png_structp png = nullptr;
    png_infop info = nullptr;
    char message[256] = "";
    ~PngIn() {
        if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
        if (file) std::fclose(file);
    }
};

void png_in_error(png_structp png, png_const_charp msg) {
    auto* r = static_cast<PngIn*>(png_get_error_ptr(png));
    std::snprintf(r->message, sizeof r->message, "%s", msg ? msg : "libpng error");
    png_longjmp(png, 1);
}
void png_in_warning(png_structp, png_const_charp) {}  // e.g. a bad sRGB chunk: not fatal

// Sets transforms that yield RGB or RGBA samples of 8 or 16 bits, values as stored (no gamma).
bool png_in_header(PngIn* r, png_uint_32* w, png_uint_32* h, int* depth, int* channels, size_t* row_bytes) {
    if (setjmp(png_jmpbuf(r->png))) return false;
    png_init_io(r->png, r->file);
    png_set_sig_bytes(r->png, 8);
    png_read_info(r->png, r->info);
    int color = png_get_color_type(r->png, r->info);
    int d = png_get_bit_depth(r->png, r->info);
    if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(r->png);
    if (color == PNG_COLOR_TYPE_GRAY && d < 8) png_set_expand_gray_1_2_4_to_8(r->png);
    if (png_get_valid(r->png, r->info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(r->png);
    if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(r->png);
    png_set_interlace_handling(r->png);
    png_read_update_info(r->png, r->info);
    *w = png_get_image_width(r->png, r->info);
    *h = png_get_image_height(r->png, r->info);
    *depth = png_get_bit_depth(r->png, r->info);
    *channels = png_get_channels(r->png, r->info);
    *row_bytes = png_get_rowbytes(r->png, r->info);
    return true;
}

bool png_in_rows(PngIn* r, png_bytepp rows) {
    if (setjmp(png_jmpbuf(r->png))) return false;
    png_read_image(r->png, rows);
    png_read_end(r->png, nullptr);
    return true;
}

ImageFile read_png_file(const std::string& path, FILE* file) {
    PngIn r;
    r.file = file;
    r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, png_in_error, png_in_warning);
    if (!r.png) fail(path, "cannot initialise libpng");
    r.info = png_create_info_struct(r.png);
    if (!r.info) fail(path, "cannot initialise libpng");
    png_uint_32 w = 0, h = 0;
    int depth = 0, nc = 0;
    size_t row_bytes = 0;
    if (!png_in_header(&r, &w, &h, &depth, &nc, &row_bytes)) fail(path, std::string("invalid PNG: ") + r.message);
    if (w == 0 || h == 0 || (unsigned long long)w * h > kMaxPixels) fail(path, "PNG has an unsupported size");
    if ((depth != 8 && depth != 16) || (nc != 3 && nc != 4) || row_bytes < size_t(w) * nc * (depth / 8))
        fail(path, "unsupported PNG layout");
    std::vector<unsigned char> pixels(row_bytes * h);
    std::vector<png_bytep> rows(h);
    for (png_uint_32 y = 0; y < h; ++y) rows[y] = pixels.data() + size_t(y) * row_bytes;
    if (!png_in_rows(&r, rows.data())) fail(path, std::string("invalid PNG: ") + r.message);

    ImageFile out;
    out.display_encoded = true;
    out.bits_per_sample = depth;
    Image& im = out.image;
    im.width = int(w);
    im.height = int(h);
    float* ch[4] = {im.add_channel("R").data(), im.add_channel("G").data(), im.add_channel("B").data(),
                    nc == 4 ? im.add_channel("A").data() : nullptr};
    for (png_uint_32 y = 0; y < h; ++y)
        for (png_uint_32 x = 0; x < w; ++x)
            for (int c = 0; c < nc; ++c) {
                size_t i = size_t(x) * nc + size_t(c);
                const unsigned char* row = rows[y];
                // 16-bit samples are big-endian in PNG; libpng leaves them so without png_set_swap.
                float v = depth == 8 ? row[i] / 255.0f : float((row[2 * i] << 8) | row[2 * i + 1]) / 65535.0f;
                ch[c][size_t(y) * w + x] = v;
            }
    return out;
}

// ---- JPEG (libjpeg) -----------------------------------------------------------------------------

struct JpegErr {
    jpeg_error_mgr mgr;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX] = "";
    int warnings = 0;
};

void jpeg_in_exit(j_common_ptr cinfo) {
    auto* e = reinterpret_cast<JpegErr*>(cinfo->err);
    (*cinfo->err->format_message)(cinfo, e->message);
    std::longjmp(e->jump, 1);
}

// libjpeg keeps decoding a truncated or corrupt stream with warnings (filling grey); we count them and
// refuse the file, since a half-grey texture would silently change the render.
void jpeg_in_message(j_common_ptr cinfo, int level) {
    auto* e = reinterpret_cast<JpegErr*>(cinfo->err);
    if (level < 0 && e->warnings++ == 0) (*cinfo->err->format_message)(cinfo, e->message);
}

struct JpegIn {
    jpeg_decompress_struct cinfo;
    JpegErr err;
    bool created = false;
};

bool jpeg_in_header(JpegIn* j, FILE* file) {
    j->cinfo.err = jpeg_std_error(&j->err.mgr);
    j->err.mgr.error_exit = jpeg_in_exit;
    j->err.mgr.emit_message = jpeg_in_message;
    if (setjmp(j->err.jump)) return false;
    jpeg_create_decompress(&j->cinfo);
    j->created = true;
    jpeg_stdio_src(&j->cinfo, file);
    jpeg_read_header(&j->cinfo, TRUE);
    j->cinfo.out_color_space = JCS_RGB;  // grey and YCbCr are converted; CMYK makes libjpeg fail
    jpeg_start_decompress(&j->cinfo);
    return true;
}

bool jpeg_in_rows(JpegIn* j, unsigned char* pixels, size_t row_bytes) {
    if (setjmp(j->err.jump)) return false;
    while (j->cinfo.output_scanline < j->cinfo.output_height) {
        JSAMPROW row = pixels + size_t(j->cinfo.output_scanline) * row_bytes;
        jpeg_read_scanlines(&j->cinfo, &row, 1);
    }
    jpeg_finish_decompress(&j->cinfo);
    return true;
}

ImageFile read_jpeg_file(const std::string& path, FILE* file) {
    JpegIn j;
    std::memset(&j.cinfo, 0, sizeof j.cinfo);
    struct Cleanup {
        JpegIn* j;
        ~Cleanup() {
            if (j->created) jpeg_destroy_decompress(&j->cinfo);
        }
    } cleanup{&j};
    if (!jpeg_in_header(&j, file)) fail(path, std::string("invalid JPEG: ") + j.err.message);
    unsigned w = j.cinfo.output_width, h = j.cinfo.output_height;
    if (w == 0 || h == 0 || (unsigned long long)w * h > kMaxPixels) fail(path, "JPEG has an unsupported size");
    if (j.cinfo.output_components != 3) fail(path, "unsupported JPEG colour layout");
    size_t row_bytes = size_t(w) * 3;
    std::vector<unsigned char> pixels(row_bytes * h);
    if (!jpeg_in_rows(&j, pixels.data(), row_bytes)) fail(path, std::string("invalid JPEG: ") + j.err.message);
    if (j.err.warnings > 0) fail(path, std::string("corrupt JPEG data: ") + j.err.message);

    ImageFile out;
    out.display_encoded = true;
    out.bits_per_sample = 8;
    Image& im = out.image;
    im.width = int(w);
    im.height = int(h);
    float* ch[3] = {im.add_channel("R").data(), im.add_channel("G").data(), im.add_channel("B").data()};
    for (size_t i = 0; i < size_t(w) * h; ++i)
        for (int c = 0; c < 3; ++c) ch[c][i] = pixels[i * 3 + c] / 255.0f;
    return out;
}

// ---- Radiance HDR (stb_image) --------------------------------------------------------------------

// stb_image reads past the end of a truncated file as if it held zeros; reading through these
// callbacks tells a complete file (stb never asks beyond its end) from a truncated one (it does).
struct HdrStream {
    FILE* file;
    bool read_past_end = false;
};
int hdr_read(void* user, char* data, int size) {
    auto* s = static_cast<HdrStream*>(user);
    size_t n = std::fread(data, 1, size_t(size), s->file);
    if (n == 0 && size > 0) s->read_past_end = true;
    return int(n);
}
void hdr_skip(void* user, int n) {
    auto* s = static_cast<HdrStream*>(user);
    if (std::fseek(s->file, n, SEEK_CUR) != 0) s->read_past_end = true;
}
int hdr_eof(void* user) {
    auto* s = static_cast<HdrStream*>(user);
    return std::feof(s->file) ? 1 : 0;
}

ImageFile read_hdr_file(const std::string& path, FILE* file) {
    int w = 0, h = 0, n = 0;
    std::rewind(file);  // stb checks the magic itself
    HdrStream stream{file};
    stbi_io_callbacks io{hdr_read, hdr_skip, hdr_eof};
    float* data = stbi_loadf_from_callbacks(&io, &stream, &w, &h, &n, 3);
    if (!data) fail(path, std::string("invalid Radiance HDR: ") + (stbi_failure_reason() ? stbi_failure_reason() : "unknown"));
    struct Free {
        float* p;
        ~Free() { stbi_image_free(p); }
    } guard{data};
    if (stream.read_past_end) fail(path, "invalid Radiance HDR: the file is truncated");
    if (w <= 0 || h <= 0 || (unsigned long long)w * h > kMaxPixels) fail(path, "HDR image has an unsupported size");
    ImageFile out;
    out.display_encoded = false;
    out.bits_per_sample = 32;
    Image& im = out.image;
    im.width = w;
    im.height = h;
    float* ch[3] = {im.add_channel("R").data(), im.add_channel("G").data(), im.add_channel("B").data()};
    for (size_t i = 0; i < size_t(w) * h; ++i)
        for (int c = 0; c < 3; ++c) ch[c][i] = data[i * 3 + c];
    return out;
}

// ---- OpenEXR ------------------------------------------------------------------------------------

ImageFile read_exr_file(const std::string& path) {
    ImageFile out;
    out.image = read_exr(path);  // throws ImageError naming the path
    out.display_encoded = false;
    out.bits_per_sample = 32;
    Image& im = out.image;
    bool has_rgb = im.channel_index("R") >= 0 && im.channel_index("G") >= 0 && im.channel_index("B") >= 0;
    if (!has_rgb) {
        int y = im.channel_index("Y");
        if (y < 0) fail(path, "EXR has no R, G, B (or Y) channels");
        std::vector<float> lum = im.data[size_t(y)];
        for (const char* name : {"R", "G", "B"})
            if (im.channel_index(name) < 0) im.add_channel(name) = lum;
    }
    return out;
}

void check_finite(const std::string& path, const Image& im) {
    for (size_t c = 0; c < im.channels.size(); ++c)
        for (float v : im.data[c])
            if (!std::isfinite(v)) fail(path, "channel '" + im.channels[c] + "' holds a non-finite value (NaN or infinity)");
}

}  // namespace

ImageFile read_image_file(const std::string& path) {
    FILE* file = std::fopen(path.c_str(), "rb");
    if (!file) fail(path, std::string("cannot open: ") + std::strerror(errno));
    unsigned char magic[10] = {};
    size_t got = std::fread(magic, 1, sizeof magic, file);
    static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (got >= 8 && std::memcmp(magic, kPng, 8) == 0) {
        std::fseek(file, 8, SEEK_SET);
        return read_png_file(path, file);  // closes the file
    }
    ImageFile out;
    try {
        if (got >= 3 && magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF) {
            std::rewind(file);
            out = read_jpeg_file(path, file);
        } else if (got >= 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01) {
            out = read_exr_file(path);
        } else if (got >= 2 && magic[0] == '#' && magic[1] == '?') {  // "#?RADIANCE" or "#?RGBE"
            out = read_hdr_file(path, file);
        } else {
            fail(path, got == 0 ? "empty image file" : "unrecognised image format (expected PNG, JPEG, OpenEXR or Radiance HDR)");
        }
    } catch (...) {
        std::fclose(file);
        throw;
    }
    std::fclose(file);
    check_finite(path, out.image);
    return out;
}

}  // namespace iris
