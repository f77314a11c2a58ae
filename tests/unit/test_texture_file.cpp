// Bitmap textures from files: 8-bit PNGs are sRGB-decoded by default, EXRs stay linear, `gamma`
// overrides both, `channel` picks one channel (alpha undecoded); the options reach the Texture.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "formats/exr.h"
#include "formats/png.h"
#include "formats/texture_file.h"

namespace fs = std::filesystem;

namespace iris {
namespace {

struct Dir {
    fs::path p = fs::temp_directory_path() / ("iris_test_texture_file_" + std::to_string(getpid()));
    Dir() { fs::create_directories(p); }
    ~Dir() {
        std::error_code ec;
        fs::remove_all(p, ec);
    }
    std::string operator()(const std::string& n) const { return (p / n).string(); }
};

TEST(TextureFile, PngIsSrgbDecodedUnlessGammaSaysOtherwise) {
    Dir d;
    // write_png stores its values as given (display encoding), rounded to 8 bits: 0, 128/255, 1.
    write_png(d("t.png"), 3, 1, {0.0f, 0.0f, 0.0f, 128 / 255.0f, 128 / 255.0f, 128 / 255.0f, 1.0f, 0.5f, 0.0f});
    Texture t = load_bitmap_texture(d("t.png"), {});
    ASSERT_EQ(t.width, 3);
    ASSERT_EQ(t.height, 1);
    EXPECT_FLOAT_EQ(t.texels[0].r, 0.0f);
    EXPECT_NEAR(t.texels[1].g, 0.215861f, 1e-6f);  // sRGB curve at 128/255
    EXPECT_FLOAT_EQ(t.texels[2].r, 1.0f);

    BitmapOptions linear;
    linear.gamma = 1;
    EXPECT_FLOAT_EQ(load_bitmap_texture(d("t.png"), linear).texels[1].g, 128 / 255.0f);
    BitmapOptions g22;
    g22.gamma = 2.2f;
    EXPECT_NEAR(load_bitmap_texture(d("t.png"), g22).texels[1].b, std::pow(128 / 255.0f, 2.2f), 1e-6f);

    BitmapOptions green;
    green.channel = "g";
    Texture tg = load_bitmap_texture(d("t.png"), green);
    // Pixel 2 is (1, 128/255 written as 0.5 -> 128, 0): the green channel, sRGB-decoded, on all three.
    EXPECT_NEAR(tg.texels[2].r, 0.215861f, 1e-6f);
    EXPECT_FLOAT_EQ(tg.texels[2].r, tg.texels[2].b);
}

TEST(TextureFile, ExrStaysLinearAndOptionsReachTheTexture) {
    Dir d;
    Image im;
    im.width = 1;
    im.height = 2;
    im.add_channel("R") = {0.5f, 2.0f};
    im.add_channel("G") = {0.25f, 0.0f};
    im.add_channel("B") = {0.125f, 1.0f};
    im.add_channel("A") = {0.5f, 1.0f};
    write_exr(d("t.exr"), im);
    BitmapOptions o;
    o.filter = TextureFilter::Nearest;
    o.wrap_u = WrapMode::Mirror;
    o.wrap_v = WrapMode::One;
    o.uscale = 2;
    o.voffset = 0.5f;
    Texture t = load_bitmap_texture(d("t.exr"), o);
    EXPECT_FLOAT_EQ(t.texels[0].r, 0.5f);
    EXPECT_FLOAT_EQ(t.texels[1].r, 2.0f);
    EXPECT_FLOAT_EQ(t.texels[0].b, 0.125f);
    EXPECT_EQ(t.filter, TextureFilter::Nearest);
    EXPECT_EQ(t.wrap_u, WrapMode::Mirror);
    EXPECT_EQ(t.wrap_v, WrapMode::One);
    EXPECT_FLOAT_EQ(t.uscale, 2.0f);
    EXPECT_FLOAT_EQ(t.voffset, 0.5f);
    // v = 0.25 + 0.5 = 0.75: the second row.
    EXPECT_FLOAT_EQ(texture_eval(t, {0.25f, 0.25f}).r, 2.0f);

    BitmapOptions srgb;
    srgb.gamma = -1;  // forced sRGB on a float file
    EXPECT_NEAR(load_bitmap_texture(d("t.exr"), srgb).texels[0].r, 0.214041f, 1e-6f);
    BitmapOptions alpha;
    alpha.channel = "a";
    alpha.gamma = -1;  // alpha is never decoded
    EXPECT_FLOAT_EQ(load_bitmap_texture(d("t.exr"), alpha).texels[0].g, 0.5f);
}

TEST(TextureFile, BadOptionsNameTheFile) {
    Dir d;
    write_png(d("t.png"), 1, 1, {0.5f, 0.5f, 0.5f});
    auto error = [](const std::string& p, const BitmapOptions& o) -> std::string {
        try {
            load_bitmap_texture(p, o);
        } catch (const ImageError& e) {
            return e.what();
        }
        return "";
    };
    BitmapOptions a;
    a.channel = "a";
    EXPECT_EQ(error(d("t.png"), a), d("t.png") + ": the image has no channel \"a\"");
    BitmapOptions x;
    x.channel = "x";
    EXPECT_EQ(error(d("t.png"), x), d("t.png") + ": channel must be r, g, b or a, not \"x\"");
    BitmapOptions g;
    g.gamma = -2;
    EXPECT_EQ(error(d("t.png"), g), d("t.png") + ": gamma must be 0 (automatic), -1 (sRGB) or positive");
    EXPECT_EQ(error(d("missing.png"), {}).rfind(d("missing.png") + ": cannot open", 0), 0u);
}

}  // namespace
}  // namespace iris
