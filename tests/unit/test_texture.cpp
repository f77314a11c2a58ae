// Texture lookups against texels computed by hand: nearest and bilinear filtering, every wrap mode on
// both sides of [0, 1), the texture's scale and offset, the sRGB curve, and Mitsuba's checkerboard.
#include <gtest/gtest.h>

#include "libcommon/texture.h"

namespace iris {
namespace {

// 2x2 texture, row 0 = top (v near 0): top-left red, top-right green, bottom-left blue, bottom-right white.
Texture two_by_two(TextureFilter f, WrapMode w) {
    Texture t;
    t.type = TextureType::Bitmap;
    t.width = 2;
    t.height = 2;
    t.texels = {RGB(1, 0, 0), RGB(0, 1, 0), RGB(0, 0, 1), RGB(1, 1, 1)};
    t.filter = f;
    t.wrap_u = t.wrap_v = w;
    return t;
}

void expect_rgb(RGB got, RGB want, const char* what) {
    EXPECT_NEAR(got.r, want.r, 1e-6f) << what;
    EXPECT_NEAR(got.g, want.g, 1e-6f) << what;
    EXPECT_NEAR(got.b, want.b, 1e-6f) << what;
}

TEST(Texture, NearestPicksTheTexelContainingUv) {
    Texture t = two_by_two(TextureFilter::Nearest, WrapMode::Repeat);
    expect_rgb(texture_eval(t, {0.25f, 0.25f}), RGB(1, 0, 0), "top-left");
    expect_rgb(texture_eval(t, {0.75f, 0.25f}), RGB(0, 1, 0), "top-right");
    expect_rgb(texture_eval(t, {0.25f, 0.75f}), RGB(0, 0, 1), "bottom-left");
    expect_rgb(texture_eval(t, {0.99f, 0.99f}), RGB(1, 1, 1), "bottom-right");
}

TEST(Texture, BilinearInterpolatesBetweenTexelCentres) {
    Texture t = two_by_two(TextureFilter::Bilinear, WrapMode::Clamp);
    expect_rgb(texture_eval(t, {0.25f, 0.25f}), RGB(1, 0, 0), "at a centre");
    expect_rgb(texture_eval(t, {0.5f, 0.5f}), RGB(0.5f, 0.5f, 0.5f), "between all four");
    // x = 0.375 * 2 - 0.5 = 0.25 past the first centre: 0.75 red + 0.25 green.
    expect_rgb(texture_eval(t, {0.375f, 0.25f}), RGB(0.75f, 0.25f, 0), "a quarter along u");
    // y = 0.5 * 2 - 0.5 = 0.5 between the rows, x at the left centre: half red, half blue.
    expect_rgb(texture_eval(t, {0.25f, 0.5f}), RGB(0.5f, 0, 0.5f), "half along v");
}

TEST(Texture, NearestWrapModesOutsideTheUnitSquare) {
    struct Case {
        WrapMode m;
        RGB at_1_25, at_minus_0_25, at_1_75;  // u at v = 0.25 (top row): texel index 2, -1, 3
    };
    const RGB red(1, 0, 0), green(0, 1, 0);
    const Case cases[] = {
        {WrapMode::Repeat, red, green, green},   // 2 -> 0, -1 -> 1, 3 -> 1
        {WrapMode::Mirror, green, red, red},     // 2 -> 1, -1 -> 0, 3 -> 0
        {WrapMode::Clamp, green, red, green},    // 2 -> 1, -1 -> 0, 3 -> 1
        {WrapMode::Zero, RGB(0), RGB(0), RGB(0)},
        {WrapMode::One, RGB(1), RGB(1), RGB(1)},
    };
    for (const Case& c : cases) {
        Texture t = two_by_two(TextureFilter::Nearest, c.m);
        SCOPED_TRACE(int(c.m));
        expect_rgb(texture_eval(t, {1.25f, 0.25f}), c.at_1_25, "u = 1.25");
        expect_rgb(texture_eval(t, {-0.25f, 0.25f}), c.at_minus_0_25, "u = -0.25");
        expect_rgb(texture_eval(t, {1.75f, 0.25f}), c.at_1_75, "u = 1.75");
        // Inside, every mode reads the texel itself.
        expect_rgb(texture_eval(t, {0.75f, 0.75f}), RGB(1, 1, 1), "inside");
    }
    // Wrap modes are per axis: repeat in u, zero in v.
    Texture t = two_by_two(TextureFilter::Nearest, WrapMode::Repeat);
    t.wrap_v = WrapMode::Zero;
    expect_rgb(texture_eval(t, {1.25f, 0.25f}), red, "u repeats");
    expect_rgb(texture_eval(t, {0.25f, 1.25f}), RGB(0), "v is zero outside");
    t.wrap_v = WrapMode::Repeat;
    expect_rgb(texture_eval(t, {0.25f, 1.25f}), red, "v repeats");
    expect_rgb(texture_eval(t, {0.25f, -0.25f}), RGB(0, 0, 1), "v = -0.25 repeats to the bottom row");
}

TEST(Texture, BilinearAtTheEdgeBlendsWithTheWrappedNeighbour) {
    // u = 0: x = -0.5, half-way between texel -1 (wrapped) and texel 0 (red), in the top row.
    const RGB red(1, 0, 0);
    struct Case {
        WrapMode m;
        RGB want;
    } cases[] = {
        {WrapMode::Repeat, RGB(0.5f, 0.5f, 0)},  // texel -1 -> 1 (green)
        {WrapMode::Mirror, red},                 // -1 -> 0 (red)
        {WrapMode::Clamp, red},
        {WrapMode::Zero, RGB(0.5f, 0, 0)},
        {WrapMode::One, RGB(1, 0.5f, 0.5f)},
    };
    for (const Case& c : cases) {
        Texture t = two_by_two(TextureFilter::Bilinear, c.m);
        t.wrap_v = WrapMode::Clamp;  // v = 0.25 is a row centre; keep v out of it
        SCOPED_TRACE(int(c.m));
        expect_rgb(texture_eval(t, {0.0f, 0.25f}), c.want, "u = 0");
    }
}

TEST(Texture, ScaleAndOffsetApplyBeforeTheLookup) {
    Texture t = two_by_two(TextureFilter::Nearest, WrapMode::Repeat);
    t.uscale = 2;
    t.uoffset = 0.25f;  // u' = 2 * 0.25 + 0.25 = 0.75: right column
    expect_rgb(texture_eval(t, {0.25f, 0.25f}), RGB(0, 1, 0), "uscale + uoffset");
    t.uscale = 1;
    t.uoffset = 0;
    t.vscale = 0.5f;
    t.voffset = 0.5f;  // v' = 0.5 * 0.5 + 0.5 = 0.75: bottom row
    expect_rgb(texture_eval(t, {0.25f, 0.5f}), RGB(0, 0, 1), "vscale + voffset");
}

TEST(Texture, SrgbCurve) {
    EXPECT_FLOAT_EQ(srgb_to_linear(0.0f), 0.0f);
    EXPECT_FLOAT_EQ(srgb_to_linear(1.0f), 1.0f);
    EXPECT_NEAR(srgb_to_linear(0.04f), 0.04f / 12.92f, 1e-7f);        // linear toe
    EXPECT_NEAR(srgb_to_linear(0.5f), 0.214041f, 1e-6f);              // ((0.5 + 0.055) / 1.055)^2.4
    EXPECT_NEAR(srgb_to_linear(128.0f / 255.0f), 0.215861f, 1e-6f);
    EXPECT_NEAR(gamma_to_linear(0.5f, 2.2f), 0.217638f, 1e-6f);       // 0.5^2.2
}

TEST(Texture, CheckerboardFollowsMitsuba) {
    Texture t;
    t.type = TextureType::Checkerboard;  // defaults: color0 0.4, color1 0.2, squares of 0.5
    EXPECT_FLOAT_EQ(texture_eval(t, {0.1f, 0.1f}).r, 0.4f);
    EXPECT_FLOAT_EQ(texture_eval(t, {0.6f, 0.1f}).r, 0.2f);
    EXPECT_FLOAT_EQ(texture_eval(t, {0.1f, 0.6f}).g, 0.2f);
    EXPECT_FLOAT_EQ(texture_eval(t, {0.6f, 0.6f}).b, 0.4f);
    // Mitsuba truncates towards zero: (-0.1) * 2 -> cell 0, (-0.6) * 2 -> cell -1 (odd).
    EXPECT_FLOAT_EQ(texture_eval(t, {-0.1f, 0.1f}).r, 0.4f);
    EXPECT_FLOAT_EQ(texture_eval(t, {-0.6f, 0.1f}).r, 0.2f);
    t.color0 = RGB(1, 0, 0);
    t.color1 = RGB(0, 0, 1);
    t.uscale = 2;  // u' = 0.6: second column
    expect_rgb(texture_eval(t, {0.3f, 0.1f}), RGB(0, 0, 1), "scaled");
    t.voffset = 0.5f;  // v' = 0.6
    expect_rgb(texture_eval(t, {0.3f, 0.1f}), RGB(1, 0, 0), "offset");
}

TEST(Texture, NonFiniteCoordinatesStayInRange) {
    Texture t = two_by_two(TextureFilter::Bilinear, WrapMode::Repeat);
    const float nan = std::nanf("");
    RGB a = texture_eval(t, {nan, 0.25f});
    RGB b = texture_eval(t, {1e30f, -1e30f});
    for (RGB c : {a, b})
        for (int i = 0; i < 3; ++i) {
            EXPECT_GE(c[i], 0.0f);
            EXPECT_LE(c[i], 1.0f);
        }
}

}  // namespace
}  // namespace iris
