// EXR and PNG images: round trips of values, layers and metadata; the atomic write (no temporary file
// left behind, the old file untouched on failure); clear ImageErrors naming the path for missing,
// foreign and truncated files; data windows with an offset; PNGs of several layouts.
#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <vector>

#include "formats/exr.h"

#include <ImfHeader.h>
#include <ImfRgbaFile.h>
#include <ImfStringAttribute.h>

namespace fs = std::filesystem;

namespace iris {
namespace {

// A scratch directory per test, removed afterwards.
class ImageFiles : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("iris_test_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + std::to_string(getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    // Files in the scratch directory whose name contains ".tmp-" (left-over temporaries).
    int temporaries() const {
        int n = 0;
        for (const auto& e : fs::directory_iterator(dir_))
            if (e.path().filename().string().find(".tmp-") != std::string::npos) ++n;
        return n;
    }
    fs::path dir_;
};

std::string read_bytes(const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

void write_bytes(const std::string& p, const std::string& bytes) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), std::streamsize(bytes.size()));
}

// Expects `f` to throw an ImageError whose message names `p`; returns the message.
template <class F>
std::string expect_image_error(F&& f, const std::string& p) {
    try {
        f();
    } catch (const ImageError& e) {
        std::string msg = e.what();
        EXPECT_NE(msg.find(p), std::string::npos) << "message does not name the path: " << msg;
        EXPECT_EQ(msg.find('\n'), std::string::npos) << "message spans lines: " << msg;
        return msg;
    } catch (const std::exception& e) {
        ADD_FAILURE() << "expected ImageError, got: " << e.what();
        return "";
    }
    ADD_FAILURE() << "expected ImageError for " << p;
    return "";
}

Image test_image(int w, int h) {
    Image img;
    img.width = w;
    img.height = h;
    const char* names[] = {"R", "G", "B", "variance.R", "variance.G", "variance.B", "samples"};
    int k = 0;
    for (const char* n : names) {
        auto& c = img.add_channel(n);
        for (int i = 0; i < w * h; ++i) c[i] = float(k * 1000 + i) * 0.37f - 5.0f;
        ++k;
    }
    // Values a lossy or half-precision path would not keep.
    img.data[0][0] = 1e30f;
    img.data[0][1] = -1e-40f;  // denormal
    img.data[1][2] = 0.1f;
    img.data[2][3] = 65519.0f + 0.5f;
    img.metadata["iris.tool"] = "render";
    img.metadata["iris.command"] = "render scene.xml -o out.exr --spp 64";
    img.metadata["iris.empty"] = "";
    img.metadata["iris.unicode"] = "caf\xc3\xa9 \xe2\x9c\x93";
    return img;
}

// Minimal parse of an EXR header: attribute name -> (type, offset of value, size).
struct Attr {
    std::string type;
    size_t offset = 0;
    int32_t size = 0;
};
std::map<std::string, Attr> parse_header(const std::string& b, size_t* header_end) {
    std::map<std::string, Attr> attrs;
    size_t i = 8;  // magic number and version
    while (i < b.size() && b[i] != 0) {
        std::string name = b.c_str() + i;
        i += name.size() + 1;
        std::string type = b.c_str() + i;
        i += type.size() + 1;
        int32_t size;
        std::memcpy(&size, b.data() + i, 4);
        i += 4;
        attrs[name] = {type, i, size};
        i += size_t(size);
    }
    *header_end = i + 1;
    return attrs;
}

TEST_F(ImageFiles, ExrRoundTripKeepsValuesLayersAndMetadata) {
    Image img = test_image(7, 5);
    const std::string p = path("image.exr");
    write_exr(p, img);
    EXPECT_EQ(temporaries(), 0);
    Image back = read_exr(p);
    ASSERT_EQ(back.width, 7);
    ASSERT_EQ(back.height, 5);
    ASSERT_EQ(back.channels.size(), img.channels.size());
    for (size_t c = 0; c < img.channels.size(); ++c) {
        int bc = back.channel_index(img.channels[c]);
        ASSERT_GE(bc, 0) << img.channels[c];
        ASSERT_EQ(back.data[bc].size(), img.data[c].size());
        for (size_t i = 0; i < img.data[c].size(); ++i)
            EXPECT_EQ(std::memcmp(&back.data[bc][i], &img.data[c][i], 4), 0) << img.channels[c] << " " << i;
    }
    for (const auto& [k, v] : img.metadata) {
        ASSERT_TRUE(back.metadata.count(k)) << k;
        EXPECT_EQ(back.metadata.at(k), v);
    }
    // On disk: ZIP compression (3) and 32-bit float (2) for every channel.
    size_t end = 0;
    std::string bytes = read_bytes(p);
    auto attrs = parse_header(bytes, &end);
    ASSERT_TRUE(attrs.count("compression"));
    EXPECT_EQ(int(bytes[attrs["compression"].offset]), 3);
    const Attr& ch = attrs["channels"];
    size_t i = ch.offset;
    int channels = 0;
    while (bytes[i] != 0) {
        std::string name = bytes.c_str() + i;
        i += name.size() + 1;
        int32_t type;
        std::memcpy(&type, bytes.data() + i, 4);
        EXPECT_EQ(type, 2) << name;
        i += 16;
        ++channels;
    }
    EXPECT_EQ(channels, 7);
    // Overwriting an existing file works (rename replaces it).
    img.metadata["iris.tool"] = "second";
    write_exr(p, img);
    EXPECT_EQ(read_exr(p).metadata.at("iris.tool"), "second");
}

TEST_F(ImageFiles, ExrRejectsNonFiniteAndLeavesOldFile) {
    const std::string p = path("keep.exr");
    Image good = test_image(4, 3);
    write_exr(p, good);
    const std::string before = read_bytes(p);
    const float inf = std::numeric_limits<float>::infinity();
    for (float bad : {std::nanf(""), inf, -inf}) {
        Image img = test_image(4, 3);
        img.data[4][7] = bad;
        std::string msg = expect_image_error([&] { write_exr(p, img); }, p);
        EXPECT_NE(msg.find("variance.G"), std::string::npos) << msg;
        EXPECT_EQ(read_bytes(p), before);
        EXPECT_EQ(temporaries(), 0);
    }
    EXPECT_FALSE(fs::exists(path("never.exr")));
    Image img = test_image(4, 3);
    img.data[0][0] = std::nanf("");
    expect_image_error([&] { write_exr(path("never.exr"), img); }, path("never.exr"));
    EXPECT_FALSE(fs::exists(path("never.exr")));
}

TEST_F(ImageFiles, ExrRejectsMalformedImages) {
    Image img = test_image(4, 3);
    img.data[2].pop_back();
    expect_image_error([&] { write_exr(path("a.exr"), img); }, path("a.exr"));
    img = test_image(4, 3);
    img.metadata["dataWindow"] = "0 0 1 1";  // an attribute OpenEXR owns
    expect_image_error([&] { write_exr(path("b.exr"), img); }, path("b.exr"));
    img = test_image(4, 3);
    img.channels.push_back("extra");  // a name without data
    expect_image_error([&] { write_exr(path("c.exr"), img); }, path("c.exr"));
    Image empty;
    expect_image_error([&] { write_exr(path("d.exr"), empty); }, path("d.exr"));
    EXPECT_EQ(temporaries(), 0);
    for (const char* f : {"a.exr", "b.exr", "c.exr", "d.exr"}) EXPECT_FALSE(fs::exists(path(f)));
}

TEST_F(ImageFiles, ExrAtomicWriteLeavesNoTemporaryOnError) {
    Image img = test_image(4, 3);
    // The final name is an existing directory: the data is written to the temporary file, and the
    // rename fails; the temporary must be removed.
    fs::create_directories(path("occupied.exr"));
    expect_image_error([&] { write_exr(path("occupied.exr"), img); }, path("occupied.exr"));
    EXPECT_EQ(temporaries(), 0);
    EXPECT_TRUE(fs::is_directory(path("occupied.exr")));
    // A directory that does not exist: the temporary cannot even be created.
    const std::string missing = path("no/such/dir/out.exr");
    std::string msg = expect_image_error([&] { write_exr(missing, img); }, missing);
    EXPECT_NE(msg.find("No such file"), std::string::npos) << msg;
    EXPECT_EQ(temporaries(), 0);
}

TEST_F(ImageFiles, ExrReadErrorsNameThePath) {
    expect_image_error([&] { read_exr(path("missing.exr")); }, path("missing.exr"));
    write_bytes(path("text.exr"), "this is not an image\n");
    std::string msg = expect_image_error([&] { read_exr(path("text.exr")); }, path("text.exr"));
    EXPECT_NE(msg.find("not an OpenEXR file"), std::string::npos) << msg;
    write_bytes(path("empty.exr"), "");
    expect_image_error([&] { read_exr(path("empty.exr")); }, path("empty.exr"));
}

TEST_F(ImageFiles, ExrTruncatedFileIsAnError) {
    // Large enough for several ZIP chunks (16 scan lines each), with noisy data that compresses badly.
    Image img;
    img.width = 64;
    img.height = 64;
    for (const char* n : {"R", "G", "B"}) {
        auto& c = img.add_channel(n);
        uint32_t x = 12345;
        for (float& v : c) {
            x = x * 1664525u + 1013904223u;
            v = float(x >> 8) * 0x1p-24f;
        }
    }
    const std::string full = path("full.exr");
    write_exr(full, img);
    const std::string bytes = read_bytes(full);
    size_t header_end = 0;
    parse_header(bytes, &header_end);
    // Cut inside the pixel data, inside the offset table, and inside the header.
    for (size_t keep : {bytes.size() - 1, bytes.size() / 2, header_end + 10, header_end - 5, size_t(20)}) {
        const std::string p = path("cut_" + std::to_string(keep) + ".exr");
        write_bytes(p, bytes.substr(0, keep));
        expect_image_error([&] { read_exr(p); }, p);
    }
}

TEST_F(ImageFiles, ExrDataWindowOffsetIsHandled) {
    // Write a 4 x 3 image, then move its data window to (10, 20) - (13, 22) by patching the header
    // and the chunk's first scan-line number: an EXR as a cropping renderer would write it.
    Image img;
    img.width = 4;
    img.height = 3;
    auto& r = img.add_channel("R");
    for (int i = 0; i < 12; ++i) r[i] = float(i);
    const std::string p = path("offset.exr");
    write_exr(p, img);
    std::string bytes = read_bytes(p);
    size_t header_end = 0;
    auto attrs = parse_header(bytes, &header_end);
    ASSERT_EQ(attrs["dataWindow"].type, "box2i");
    const int32_t box[4] = {10, 20, 13, 22};
    std::memcpy(&bytes[attrs["dataWindow"].offset], box, 16);
    uint64_t chunk;
    std::memcpy(&chunk, bytes.data() + header_end, 8);  // one chunk: the offset table has one entry
    int32_t y;
    std::memcpy(&y, bytes.data() + chunk, 4);
    ASSERT_EQ(y, 0);
    y = 20;
    std::memcpy(&bytes[chunk], &y, 4);
    write_bytes(p, bytes);
    Image back = read_exr(p);
    ASSERT_EQ(back.width, 4);
    ASSERT_EQ(back.height, 3);
    ASSERT_EQ(back.channel_index("R"), 0);
    for (int i = 0; i < 12; ++i) EXPECT_EQ(back.data[0][i], float(i)) << i;
}

// Mitsuba 0.5 writes its EXRs with HALF channels and a "generatedBy" string attribute: a file of that
// shape, written here with OpenEXR's RGBA interface, reads back as floats with the attribute kept.
TEST_F(ImageFiles, ExrReadsHalfFloatChannelsAndForeignAttributes) {
    const int w = 7, h = 5;
    std::vector<Imf::Rgba> px(size_t(w) * h);
    for (int i = 0; i < w * h; ++i) px[size_t(i)] = Imf::Rgba(half(0.25f * float(i)), half(1.5f), half(-2.0f), half(1.0f));
    const std::string p = path("half.exr");
    {
        Imf::Header header(w, h);
        header.insert("generatedBy", Imf::StringAttribute("Mitsuba version 0.5.0"));
        Imf::RgbaOutputFile out(p.c_str(), header, Imf::WRITE_RGB);
        out.setFrameBuffer(px.data(), 1, size_t(w));
        out.writePixels(h);
    }
    Image img = read_exr(p);
    ASSERT_EQ(img.width, w);
    ASSERT_EQ(img.height, h);
    const int r = img.channel_index("R"), g = img.channel_index("G"), b = img.channel_index("B");
    ASSERT_GE(r, 0);
    ASSERT_GE(g, 0);
    ASSERT_GE(b, 0);
    // Every value written is exact in half precision, so the float read must equal it.
    for (int i = 0; i < w * h; ++i) {
        EXPECT_EQ(img.data[size_t(r)][size_t(i)], 0.25f * float(i)) << i;
        EXPECT_EQ(img.data[size_t(g)][size_t(i)], 1.5f) << i;
        EXPECT_EQ(img.data[size_t(b)][size_t(i)], -2.0f) << i;
    }
    ASSERT_TRUE(img.metadata.count("generatedBy"));
    EXPECT_EQ(img.metadata.at("generatedBy"), "Mitsuba version 0.5.0");
}

// ---- PNG -------------------------------------------------------------------------------------------

// Writes a PNG with libpng's simplified API: `format` is a PNG_FORMAT_* value, `pixels` 8- or 16-bit.
void write_test_png(const std::string& p, int w, int h, uint32_t format, const void* pixels) {
    png_image image;
    std::memset(&image, 0, sizeof image);
    image.version = PNG_IMAGE_VERSION;
    image.width = png_uint_32(w);
    image.height = png_uint_32(h);
    image.format = format;
    ASSERT_NE(png_image_write_to_file(&image, p.c_str(), 0, pixels, 0, nullptr), 0) << image.message;
}

TEST_F(ImageFiles, PngReads8BitRgbRgbaAndGray) {
    const int w = 3, h = 2;
    const uint8_t rgb[w * h * 3] = {0, 1, 2, 50, 100, 150, 255, 254, 253, 7, 8, 9, 200, 100, 0, 128, 64, 32};
    write_test_png(path("rgb.png"), w, h, PNG_FORMAT_RGB, rgb);
    Image img = read_png(path("rgb.png"));
    ASSERT_EQ(img.width, w);
    ASSERT_EQ(img.height, h);
    ASSERT_EQ(img.channels.size(), 3u);
    const char* names[] = {"R", "G", "B"};
    for (int i = 0; i < w * h; ++i)
        for (int c = 0; c < 3; ++c) EXPECT_EQ(img.data[img.channel_index(names[c])][i], rgb[3 * i + c] / 255.0f);

    uint8_t rgba[w * h * 4];
    for (int i = 0; i < w * h; ++i) {
        for (int c = 0; c < 3; ++c) rgba[4 * i + c] = rgb[3 * i + c];
        rgba[4 * i + 3] = uint8_t(40 * i);  // alpha is dropped, not composited
    }
    write_test_png(path("rgba.png"), w, h, PNG_FORMAT_RGBA, rgba);
    img = read_png(path("rgba.png"));
    ASSERT_EQ(img.channels.size(), 3u);
    for (int i = 0; i < w * h; ++i) {
        EXPECT_EQ(img.data[img.channel_index("R")][i], rgb[3 * i] / 255.0f);
        EXPECT_EQ(img.data[img.channel_index("B")][i], rgb[3 * i + 2] / 255.0f);
    }

    const uint8_t gray[w * h] = {0, 17, 34, 128, 254, 255};
    write_test_png(path("gray.png"), w, h, PNG_FORMAT_GRAY, gray);
    img = read_png(path("gray.png"));
    for (int i = 0; i < w * h; ++i)
        for (const char* c : {"R", "G", "B"}) EXPECT_EQ(img.data[img.channel_index(c)][i], gray[i] / 255.0f);
}

TEST_F(ImageFiles, PngReads16Bit) {
    const int w = 2, h = 2;
    const uint16_t rgb[w * h * 3] = {0, 1, 2, 1000, 30000, 65535, 65534, 256, 255, 4660, 22136, 39612};
    write_test_png(path("rgb16.png"), w, h, PNG_FORMAT_LINEAR_RGB, rgb);
    Image img = read_png(path("rgb16.png"));
    ASSERT_EQ(img.width, w);
    ASSERT_EQ(img.height, h);
    const char* names[] = {"R", "G", "B"};
    for (int i = 0; i < w * h; ++i)
        for (int c = 0; c < 3; ++c) EXPECT_EQ(img.data[img.channel_index(names[c])][i], rgb[3 * i + c] / 65535.0f);
}

// A PNG written by Mitsuba 0.5 (the thesis scenes' Cornell box reference, 8-bit sRGB).
TEST_F(ImageFiles, PngReadsMitsubaImage) {
    const std::string p = std::string(IRIS_SOURCE_DIR) + "/tests/data/images/cornell_diffuse_boxes__mitsuba.png";
    Image img = read_png(p);
    EXPECT_EQ(img.width, 512);
    EXPECT_EQ(img.height, 512);
    ASSERT_EQ(img.channels.size(), 3u);
    double sum = 0;
    for (const auto& c : img.data)
        for (float v : c) {
            ASSERT_GE(v, 0.0f);
            ASSERT_LE(v, 1.0f);
            sum += v;
        }
    EXPECT_GT(sum, 0.0);
}

TEST_F(ImageFiles, PngErrorsNameThePath) {
    expect_image_error([&] { read_png(path("missing.png")); }, path("missing.png"));
    write_bytes(path("text.png"), "definitely not a png file");
    std::string msg = expect_image_error([&] { read_png(path("text.png")); }, path("text.png"));
    EXPECT_NE(msg.find("not a PNG"), std::string::npos) << msg;
    // A truncated PNG: a real one, cut in its image data and in its header.
    std::vector<uint8_t> noise(64 * 64 * 3);
    uint32_t x = 99;
    for (auto& v : noise) {
        x = x * 1664525u + 1013904223u;
        v = uint8_t(x >> 24);
    }
    write_test_png(path("full.png"), 64, 64, PNG_FORMAT_RGB, noise.data());
    const std::string bytes = read_bytes(path("full.png"));
    for (size_t keep : {bytes.size() / 2, size_t(30), size_t(8)}) {
        const std::string p = path("cut_" + std::to_string(keep) + ".png");
        write_bytes(p, bytes.substr(0, keep));
        expect_image_error([&] { read_png(p); }, p);
    }
    // The intact file still reads.
    EXPECT_EQ(read_png(path("full.png")).width, 64);
}

}  // namespace
}  // namespace iris
