// OpenEXR (via the OpenEXR 3 C++ API) and PNG (via libpng) image files.
//
// Every error becomes an ImageError whose one-line message starts with the path, so tools can print
// "<tool>: error: <message>" and the user knows which file is at fault.
#include "formats/exr.h"

#include "formats/atomic_file.h"

#include <fcntl.h>
#include <png.h>
#include <unistd.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfTestFile.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <set>

namespace iris {

int Image::channel_index(const std::string& name) const {
    for (size_t i = 0; i < channels.size(); ++i)
        if (channels[i] == name) return int(i);
    return -1;
}

std::vector<float>& Image::add_channel(const std::string& name) {
    channels.push_back(name);
    data.emplace_back(size_t(width) * size_t(height), 0.0f);
    return data.back();
}

namespace {

// Messages from OpenEXR can span lines; keep ours to one.
std::string one_line(std::string s) {
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw ImageError(path + ": " + one_line(what));
}

// An OpenEXR output stream over a POSIX file descriptor. OpenEXR's own file stream cannot be
// fsync'ed, and OutputFile's destructor (which writes the scan-line offset table) swallows I/O errors;
// this stream remembers them, so write_exr can tell a complete file from a truncated one.
class FdOStream : public Imf::OStream {
public:
    FdOStream(const char* name, int fd) : Imf::OStream(name), fd_(fd) {}
    void write(const char c[], int n) override {
        while (n > 0) {
            ssize_t w = ::write(fd_, c, size_t(n));
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) {
                error_ = w < 0 ? std::strerror(errno) : "short write";
                throw std::runtime_error("write failed: " + error_);
            }
            c += w;
            n -= int(w);
        }
    }
    uint64_t tellp() override {
        off_t pos = ::lseek(fd_, 0, SEEK_CUR);
        if (pos < 0) {
            error_ = std::strerror(errno);
            throw std::runtime_error("seek failed: " + error_);
        }
        return uint64_t(pos);
    }
    void seekp(uint64_t pos) override {
        if (::lseek(fd_, off_t(pos), SEEK_SET) < 0) {
            error_ = std::strerror(errno);
            throw std::runtime_error("seek failed: " + error_);
        }
    }
    const std::string& error() const { return error_; }

private:
    int fd_;
    std::string error_;
};

// Attribute names OpenEXR itself defines for every scan-line image: metadata may not overwrite them.
const std::set<std::string>& reserved_attributes() {
    static const std::set<std::string> names = {
        "channels", "compression", "dataWindow", "displayWindow", "lineOrder", "pixelAspectRatio",
        "screenWindowCenter", "screenWindowWidth", "tiles", "type", "name", "version", "chunkCount"};
    return names;
}

void validate_for_write(const std::string& path, const Image& image) {
    if (image.width <= 0 || image.height <= 0)
        fail(path, "cannot write an empty image (" + std::to_string(image.width) + "x" +
                       std::to_string(image.height) + ")");
    if (image.channels.empty()) fail(path, "cannot write an image without channels");
    if (image.channels.size() != image.data.size())
        fail(path, "image has " + std::to_string(image.channels.size()) + " channel names but " +
                       std::to_string(image.data.size()) + " channel buffers");
    const size_t n = size_t(image.width) * size_t(image.height);
    std::set<std::string> seen;
    for (size_t c = 0; c < image.channels.size(); ++c) {
        const std::string& name = image.channels[c];
        if (name.empty()) fail(path, "channel " + std::to_string(c) + " has an empty name");
        if (!seen.insert(name).second) fail(path, "duplicate channel '" + name + "'");
        if (image.data[c].size() != n)
            fail(path, "channel '" + name + "' has " + std::to_string(image.data[c].size()) +
                           " values, expected " + std::to_string(n));
        // The renderer guarantees finite pixels; a NaN/Inf here is a bug upstream, and writing it
        // would poison every comparison made against this file later.
        for (size_t i = 0; i < n; ++i)
            if (!std::isfinite(image.data[c][i]))
                fail(path, "channel '" + name + "' has a non-finite value (" + std::to_string(image.data[c][i]) +
                               ") at pixel (" + std::to_string(i % size_t(image.width)) + ", " +
                               std::to_string(i / size_t(image.width)) + "); refusing to write");
    }
    for (const auto& [key, value] : image.metadata) {
        if (key.empty()) fail(path, "metadata with an empty name");
        if (reserved_attributes().count(key)) fail(path, "metadata name '" + key + "' is reserved by OpenEXR");
    }
}

}  // namespace

void write_exr(const std::string& path, const Image& image) {
    validate_for_write(path, image);
    std::string error;
    try {
        AtomicFile file(path);
        Imf::Header header(image.width, image.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const std::string& name : image.channels) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        for (const auto& [key, value] : image.metadata) header.insert(key, Imf::StringAttribute(value));
        Imf::FrameBuffer fb;
        for (size_t c = 0; c < image.channels.size(); ++c)
            fb.insert(image.channels[c],
                      Imf::Slice(Imf::FLOAT, (char*)image.data[c].data(), sizeof(float),
                                 sizeof(float) * size_t(image.width)));
        FdOStream stream(file.temp_path().c_str(), file.fd());
        {
            Imf::OutputFile out(stream, header);
            out.setFrameBuffer(fb);
            out.writePixels(image.height);
        }  // the destructor writes the offset table; its I/O errors surface in stream.error()
        if (!stream.error().empty()) fail(path, "cannot write EXR: write failed: " + stream.error());
        file.commit();
    } catch (const ImageError&) {
        throw;
    } catch (const std::exception& e) {
        error = e.what();
    }
    // (AtomicFile's messages already start with the path.)
    if (!error.empty()) throw ImageError(error.rfind(path, 0) == 0 ? error : path + ": cannot write EXR: " + error);
}

Image read_exr(const std::string& path) {
    {
        int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) fail(path, std::string("cannot open: ") + std::strerror(errno));
        ::close(fd);
    }
    bool tiled = false;
    if (!Imf::isOpenExrFile(path.c_str(), tiled)) fail(path, "not an OpenEXR file");
    Image image;
    try {
        Imf::InputFile in(path.c_str());
        const Imf::Header& header = in.header();
        const Imath::Box2i dw = header.dataWindow();
        const long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
        if (w <= 0 || h <= 0 || w * h > (1LL << 31)) fail(path, "invalid data window");
        image.width = int(w);
        image.height = int(h);
        Imf::FrameBuffer fb;
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
            const Imf::Channel& ch = it.channel();
            if (ch.xSampling != 1 || ch.ySampling != 1)
                fail(path, std::string("channel '") + it.name() + "' is subsampled (not supported)");
            std::vector<float>& buf = image.add_channel(it.name());
            // OpenEXR addresses pixel (x, y) of the data window as base + x*xs + y*ys with absolute
            // coordinates: shift the base so the window's corner lands at buf[0].
            char* base = (char*)buf.data() -
                         (ptrdiff_t(dw.min.x) + ptrdiff_t(dw.min.y) * ptrdiff_t(w)) * ptrdiff_t(sizeof(float));
            // Pixels of any type (HALF, UINT) are converted to FLOAT by the library.
            fb.insert(it.name(), Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * size_t(w)));
        }
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        for (auto it = header.begin(); it != header.end(); ++it)
            if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
                image.metadata[it.name()] = s->value();
    } catch (const ImageError&) {
        throw;
    } catch (const std::exception& e) {
        fail(path, std::string("cannot read EXR: ") + e.what());
    }
    return image;
}

// ---- PNG -------------------------------------------------------------------------------------------
//
// libpng reports errors by longjmp. A longjmp must not skip C++ destructors, so the libpng calls live
// in small functions whose locals are all trivial, each with its own setjmp; the C++ objects (buffers,
// the image) live in read_png's frame, which the jump never crosses.

namespace {

struct PngReader {
    FILE* file = nullptr;
    png_structp png = nullptr;
    png_infop info = nullptr;
    char message[256] = "";
    ~PngReader() {
        if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
        if (file) std::fclose(file);
    }
};

void png_on_error(png_structp png, png_const_charp msg) {
    auto* r = static_cast<PngReader*>(png_get_error_ptr(png));
    std::snprintf(r->message, sizeof r->message, "%s", msg ? msg : "libpng error");
    png_longjmp(png, 1);
}

void png_on_warning(png_structp, png_const_charp) {}  // warnings (e.g. bad sRGB chunks) are not fatal

// Reads the header and sets the transforms that yield 3 samples per pixel of 8 or 16 bits, values as
// stored (no gamma correction, alpha dropped rather than composited).
bool png_read_header(PngReader* r, png_uint_32* width, png_uint_32* height, int* bit_depth, size_t* row_bytes) {
    if (setjmp(png_jmpbuf(r->png))) return false;
    png_init_io(r->png, r->file);
    png_set_sig_bytes(r->png, 8);
    png_read_info(r->png, r->info);
    int color = png_get_color_type(r->png, r->info);
    int depth = png_get_bit_depth(r->png, r->info);
    if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(r->png);
    if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(r->png);
    if (color & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(r->png);
    if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(r->png);
    png_set_interlace_handling(r->png);
    png_read_update_info(r->png, r->info);
    *width = png_get_image_width(r->png, r->info);
    *height = png_get_image_height(r->png, r->info);
    *bit_depth = png_get_bit_depth(r->png, r->info);
    *row_bytes = png_get_rowbytes(r->png, r->info);
    if (png_get_channels(r->png, r->info) != 3) png_error(r->png, "unexpected channel count after conversion");
    return true;
}

bool png_read_rows(PngReader* r, png_bytepp rows) {
    if (setjmp(png_jmpbuf(r->png))) return false;
    png_read_image(r->png, rows);
    png_read_end(r->png, nullptr);
    return true;
}

}  // namespace

Image read_png(const std::string& path) {
    PngReader r;
    r.file = std::fopen(path.c_str(), "rb");
    if (!r.file) fail(path, std::string("cannot open: ") + std::strerror(errno));
    unsigned char sig[8];
    if (std::fread(sig, 1, 8, r.file) != 8 || png_sig_cmp(sig, 0, 8) != 0) fail(path, "not a PNG file");
    r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, png_on_error, png_on_warning);
    if (!r.png) fail(path, "cannot initialise libpng");
    r.info = png_create_info_struct(r.png);
    if (!r.info) fail(path, "cannot initialise libpng");
    png_uint_32 width = 0, height = 0;
    int depth = 0;
    size_t row_bytes = 0;
    if (!png_read_header(&r, &width, &height, &depth, &row_bytes)) fail(path, std::string("invalid PNG: ") + r.message);
    if (width == 0 || height == 0 || (depth != 8 && depth != 16) || row_bytes < size_t(width) * 3 * (depth / 8))
        fail(path, "unsupported PNG layout");
    std::vector<unsigned char> pixels(row_bytes * height);
    std::vector<png_bytep> rows(height);
    for (png_uint_32 y = 0; y < height; ++y) rows[y] = pixels.data() + size_t(y) * row_bytes;
    if (!png_read_rows(&r, rows.data())) fail(path, std::string("invalid PNG: ") + r.message);

    Image image;
    image.width = int(width);
    image.height = int(height);
    float* ch[3] = {image.add_channel("R").data(), image.add_channel("G").data(), image.add_channel("B").data()};
    for (png_uint_32 y = 0; y < height; ++y) {
        const unsigned char* row = rows[y];
        for (png_uint_32 x = 0; x < width; ++x)
            for (int c = 0; c < 3; ++c) {
                size_t i = size_t(x) * 3 + size_t(c);
                // 16-bit samples are big-endian in PNG and libpng leaves them so without png_set_swap.
                float v = depth == 8 ? row[i] / 255.0f : ((row[2 * i] << 8) | row[2 * i + 1]) / 65535.0f;
                ch[c][size_t(y) * width + x] = v;
            }
    }
    return image;
}

}  // namespace iris
