// read_image_file: PNG (8/16-bit, grey, alpha), JPEG, OpenEXR and Radiance HDR decode to the values the
// test wrote; the sRGB flag follows the format; missing, truncated, corrupt and foreign files give one
// ImageError line that starts with the path.
#include <gtest/gtest.h>
#include <jpeglib.h>
#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "formats/exr.h"
#include "formats/image_file.h"
#include "formats/png.h"

namespace fs = std::filesystem;

namespace iris {
namespace {

class ImageFileRead : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() / ("iris_test_imagefile_" + std::string(info->name()) + "_" + std::to_string(getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    fs::path dir_;
};

// The message of the ImageError that reading `p` throws ("" if none).
std::string read_error(const std::string& p) {
    try {
        read_image_file(p);
    } catch (const ImageError& e) {
        return e.what();
    }
    return "";
}

float at(const Image& im, const char* ch, int x, int y) {
    int c = im.channel_index(ch);
    EXPECT_GE(c, 0) << ch;
    return c < 0 ? -1.0f : im.data[size_t(c)][size_t(y) * im.width + x];
}

// Writes a PNG with libpng's low-level API: `samples` are row-major, `channels` per pixel, 8 or 16 bit.
void write_test_png(const std::string& p, int w, int h, int color_type, int depth, const std::vector<unsigned>& samples) {
    FILE* f = std::fopen(p.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, f);
    png_set_IHDR(png, info, w, h, depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    int channels = int(samples.size()) / (w * h);
    std::vector<unsigned char> row(size_t(w) * channels * (depth / 8));
    for (int y = 0; y < h; ++y) {
        for (int i = 0; i < w * channels; ++i) {
            unsigned v = samples[size_t(y) * w * channels + i];
            if (depth == 8) row[i] = (unsigned char)v;
            else {
                row[2 * i] = (unsigned char)(v >> 8);
                row[2 * i + 1] = (unsigned char)(v & 0xff);
            }
        }
        png_write_row(png, row.data());
    }
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
}

void write_test_jpeg(const std::string& p, int w, int h, const std::vector<unsigned char>& rgb) {
    FILE* f = std::fopen(p.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    jpeg_compress_struct c;
    jpeg_error_mgr err;
    c.err = jpeg_std_error(&err);
    jpeg_create_compress(&c);
    jpeg_stdio_dest(&c, f);
    c.image_width = unsigned(w);
    c.image_height = unsigned(h);
    c.input_components = 3;
    c.in_color_space = JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 100, TRUE);
    jpeg_start_compress(&c, TRUE);
    for (int y = 0; y < h; ++y) {
        JSAMPROW row = const_cast<unsigned char*>(rgb.data()) + size_t(y) * w * 3;
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    std::fclose(f);
}

TEST_F(ImageFileRead, Png8BitRgbValuesAsStoredAndFlaggedDisplayEncoded) {
    write_test_png(path("a.png"), 2, 1, PNG_COLOR_TYPE_RGB, 8, {0, 128, 255, 51, 102, 204});
    ImageFile f = read_image_file(path("a.png"));
    EXPECT_TRUE(f.display_encoded);
    EXPECT_EQ(f.bits_per_sample, 8);
    ASSERT_EQ(f.image.width, 2);
    ASSERT_EQ(f.image.height, 1);
    EXPECT_EQ(f.image.channel_index("A"), -1);
    EXPECT_FLOAT_EQ(at(f.image, "R", 0, 0), 0.0f);
    EXPECT_FLOAT_EQ(at(f.image, "G", 0, 0), 128.0f / 255.0f);
    EXPECT_FLOAT_EQ(at(f.image, "B", 0, 0), 1.0f);
    EXPECT_FLOAT_EQ(at(f.image, "R", 1, 0), 0.2f);
    EXPECT_FLOAT_EQ(at(f.image, "G", 1, 0), 0.4f);
    EXPECT_FLOAT_EQ(at(f.image, "B", 1, 0), 0.8f);
}

TEST_F(ImageFileRead, Png16BitGreyAlphaExpandsToRgbaInRowOrder) {
    // 1x2: top pixel grey 65535 alpha 0, bottom grey 13107 (0.2) alpha 32768.
    write_test_png(path("g.png"), 1, 2, PNG_COLOR_TYPE_GRAY_ALPHA, 16, {65535, 0, 13107, 32768});
    ImageFile f = read_image_file(path("g.png"));
    EXPECT_EQ(f.bits_per_sample, 16);
    for (const char* c : {"R", "G", "B"}) {
        EXPECT_FLOAT_EQ(at(f.image, c, 0, 0), 1.0f);
        EXPECT_FLOAT_EQ(at(f.image, c, 0, 1), 0.2f);
    }
    EXPECT_FLOAT_EQ(at(f.image, "A", 0, 0), 0.0f);
    EXPECT_FLOAT_EQ(at(f.image, "A", 0, 1), 32768.0f / 65535.0f);
}

TEST_F(ImageFileRead, JpegDecodesAFlatColourWithinQuantisation) {
    std::vector<unsigned char> rgb;
    for (int i = 0; i < 16 * 8; ++i) rgb.insert(rgb.end(), {200, 100, 50});
    write_test_jpeg(path("c.jpg"), 16, 8, rgb);
    ImageFile f = read_image_file(path("c.jpg"));
    EXPECT_TRUE(f.display_encoded);
    ASSERT_EQ(f.image.width, 16);
    ASSERT_EQ(f.image.height, 8);
    // Quality 100 with 4:2:0 chroma: a flat colour survives within a few steps of 1/255.
    for (int y : {0, 7})
        for (int x : {0, 15}) {
            EXPECT_NEAR(at(f.image, "R", x, y), 200 / 255.0f, 3 / 255.0f);
            EXPECT_NEAR(at(f.image, "G", x, y), 100 / 255.0f, 3 / 255.0f);
            EXPECT_NEAR(at(f.image, "B", x, y), 50 / 255.0f, 3 / 255.0f);
        }
}

TEST_F(ImageFileRead, ExrKeepsLinearFloatsAndExpandsLuminance) {
    Image im;
    im.width = 2;
    im.height = 1;
    im.add_channel("R") = {1.5f, 0.0f};
    im.add_channel("G") = {2.5f, 0.125f};
    im.add_channel("B") = {100.0f, 0.0f};
    write_exr(path("rgb.exr"), im);
    ImageFile f = read_image_file(path("rgb.exr"));
    EXPECT_FALSE(f.display_encoded);
    EXPECT_FLOAT_EQ(at(f.image, "R", 0, 0), 1.5f);
    EXPECT_FLOAT_EQ(at(f.image, "B", 0, 0), 100.0f);
    EXPECT_FLOAT_EQ(at(f.image, "G", 1, 0), 0.125f);

    Image y;
    y.width = 1;
    y.height = 1;
    y.add_channel("Y") = {3.0f};
    write_exr(path("y.exr"), y);
    ImageFile g = read_image_file(path("y.exr"));
    for (const char* c : {"R", "G", "B"}) EXPECT_FLOAT_EQ(at(g.image, c, 0, 0), 3.0f);
}

TEST_F(ImageFileRead, RadianceHdrDecodesRgbe) {
    // Two flat (not run-length encoded: width < 8) RGBE pixels. (128,64,32,e=129) is
    // mantissa/256 * 2^(129-128) = (1, 0.5, 0.25); (255,0,0,e=128-8+...) checks a second exponent.
    std::string header = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n";
    unsigned char px[8] = {128, 64, 32, 129, 192, 0, 64, 131};  // second: (0.75, 0, 0.25) * 8 = (6, 0, 2)
    std::ofstream(path("e.hdr"), std::ios::binary) << header << std::string(reinterpret_cast<char*>(px), 8);
    ImageFile f = read_image_file(path("e.hdr"));
    EXPECT_FALSE(f.display_encoded);
    ASSERT_EQ(f.image.width, 2);
    ASSERT_EQ(f.image.height, 1);
    // stb_image adds no half-step offset: value = m * 2^(e - 136).
    EXPECT_FLOAT_EQ(at(f.image, "R", 0, 0), 1.0f);
    EXPECT_FLOAT_EQ(at(f.image, "G", 0, 0), 0.5f);
    EXPECT_FLOAT_EQ(at(f.image, "B", 0, 0), 0.25f);
    EXPECT_FLOAT_EQ(at(f.image, "R", 1, 0), 6.0f);
    EXPECT_FLOAT_EQ(at(f.image, "G", 1, 0), 0.0f);
    EXPECT_FLOAT_EQ(at(f.image, "B", 1, 0), 2.0f);
}

TEST_F(ImageFileRead, BadFilesGiveOneLineNamingThePath) {
    std::string missing = path("missing.png");
    std::string e = read_error(missing);
    EXPECT_EQ(e.rfind(missing + ": cannot open", 0), 0u) << e;

    // A PNG cut in half: libpng's error, prefixed by the path.
    std::vector<unsigned> s(64 * 64 * 3);
    for (size_t i = 0; i < s.size(); ++i) s[i] = unsigned(i * 7919 % 256);
    write_test_png(path("full.png"), 64, 64, PNG_COLOR_TYPE_RGB, 8, s);
    std::string bytes;
    {
        std::ifstream in(path("full.png"), std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    std::ofstream(path("cut.png"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    e = read_error(path("cut.png"));
    EXPECT_EQ(e.rfind(path("cut.png") + ": invalid PNG", 0), 0u) << e;

    // A JPEG cut short: libjpeg would fill grey with a warning; we refuse it.
    std::vector<unsigned char> rgb(64 * 64 * 3);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = (unsigned char)(i * 31 % 256);
    write_test_jpeg(path("full.jpg"), 64, 64, rgb);
    {
        std::ifstream in(path("full.jpg"), std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    std::ofstream(path("cut.jpg"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    e = read_error(path("cut.jpg"));
    EXPECT_EQ(e.rfind(path("cut.jpg") + ": ", 0), 0u) << e;
    EXPECT_NE(e.find("JPEG"), std::string::npos) << e;

    std::ofstream(path("text.png")) << "hello, not an image\n";
    e = read_error(path("text.png"));
    EXPECT_EQ(e, path("text.png") + ": unrecognised image format (expected PNG, JPEG, OpenEXR or Radiance HDR)");

    std::ofstream(path("empty.exr")).close();
    EXPECT_EQ(read_error(path("empty.exr")), path("empty.exr") + ": empty image file");

    std::ofstream(path("bad.hdr"), std::ios::binary) << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n\x01";
    e = read_error(path("bad.hdr"));
    EXPECT_EQ(e.rfind(path("bad.hdr") + ": invalid Radiance HDR", 0), 0u) << e;

    // write_exr refuses NaN, so write 1.25 and patch its bytes: a 1x1 image is stored uncompressed
    // (ZIP would not make 12 bytes smaller), so the float's bytes appear as written.
    Image one;
    one.width = 1;
    one.height = 1;
    one.add_channel("R") = {1.25f};
    one.add_channel("G") = {0.0f};
    one.add_channel("B") = {0.0f};
    write_exr(path("nan.exr"), one);
    {
        std::ifstream in(path("nan.exr"), std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    float v = 1.25f, q = std::numeric_limits<float>::quiet_NaN();
    std::string needle(reinterpret_cast<char*>(&v), 4), nan_bytes(reinterpret_cast<char*>(&q), 4);
    size_t at_value = bytes.rfind(needle);
    ASSERT_NE(at_value, std::string::npos);
    bytes.replace(at_value, 4, nan_bytes);
    std::ofstream(path("nan.exr"), std::ios::binary) << bytes;
    e = read_error(path("nan.exr"));
    EXPECT_EQ(e, path("nan.exr") + ": channel 'R' holds a non-finite value (NaN or infinity)");

    for (const std::string& f : {missing, path("cut.png"), path("cut.jpg")}) {
        std::string m = read_error(f);
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
}

}  // namespace
}  // namespace iris
