// Spectrum -> RGB conversion against the values in scenes/thesis/README.md (Mitsuba 0.5 RGB mode),
// plus the colour-space helpers and the named-material tables.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "libcommon/spectrum.h"

using namespace iris;

namespace {

struct Sampled {
    std::vector<float> w, v;
};

Sampled parse_pairs(const std::string& text) {
    Sampled s;
    std::stringstream ss(text);
    std::string tok;
    while (std::getline(ss, tok, ',')) {
        size_t colon = tok.find(':');
        s.w.push_back(std::stof(tok.substr(0, colon)));
        s.v.push_back(std::stof(tok.substr(colon + 1)));
    }
    return s;
}

// The reflectance spectrum of the bsdf with this id in cbox_kugeln.xml (the full seed spectra).
Sampled cbox_reflectance(const std::string& id) {
    std::ifstream in(std::string(IRIS_SOURCE_DIR) + "/scenes/thesis/cbox_kugeln.xml");
    std::stringstream buf;
    buf << in.rdbuf();
    std::string xml = buf.str();
    std::regex re("id=\"" + id + "\">\\s*<spectrum name=\"reflectance\" value=\"([^\"]+)\"");
    std::smatch m;
    EXPECT_TRUE(std::regex_search(xml, m, re)) << id;
    return parse_pairs(m[1]);
}

void expect_rgb(RGB c, float r, float g, float b, float tol, const char* what) {
    EXPECT_NEAR(c.r, r, tol) << what;
    EXPECT_NEAR(c.g, g, tol) << what;
    EXPECT_NEAR(c.b, b, tol) << what;
}

}  // namespace

// The bold README values: measured with Mitsuba on constant emitters. These only come out with both
// Mitsuba quirks (zero extension, backwards segment interpolation) and its float Gauss-Lobatto rule.
TEST(Spectrum, EmitterOfEmptyAndMirrorBoxesMatchesMitsuba) {
    Sampled s = parse_pairs("400:0, 500:8, 600:15.6, 700:18.4");
    expect_rgb(spectrum_to_rgb(s.w, s.v), 18.387f, 10.987f, 2.754f, 1.5e-3f, "emitter 18.4");
}

TEST(Spectrum, EmitterOfGlassSpheresMatchesMitsuba) {
    Sampled s = parse_pairs("400:0, 500:16, 600:30, 700:37");
    expect_rgb(spectrum_to_rgb(s.w, s.v), 36.813f, 21.336f, 5.542f, 1.5e-3f, "emitter 37");
}

TEST(Spectrum, ExactIntegralOfEmitters) {
    Sampled a = parse_pairs("400:0, 500:8, 600:15.6, 700:18.4");
    expect_rgb(spectrum_to_rgb_exact(a.w, a.v), 20.714f, 10.855f, 2.771f, 1.5e-3f, "exact 18.4");
    Sampled b = parse_pairs("400:0, 500:16, 600:30, 700:37");
    expect_rgb(spectrum_to_rgb_exact(b.w, b.v), 40.093f, 21.209f, 5.624f, 1.5e-3f, "exact 37");
}

TEST(Spectrum, FlatSpectrumIsWarmWithoutWhiteBalance) {
    Sampled s = parse_pairs("400:1, 500:1, 600:1, 700:1");
    expect_rgb(spectrum_to_rgb(s.w, s.v), 1.20f, 0.95f, 0.90f, 0.01f, "flat");
    expect_rgb(spectrum_to_rgb_exact(s.w, s.v), 1.20f, 0.95f, 0.90f, 0.01f, "flat exact");
}

// The README's reflectance rows were computed with the exact integral; Mitsuba's own conversion
// (zero extension + backwards interpolation) differs from them by up to 6e-4, and equals Mitsuba 3's
// RGB Cornell-box constants (converted with Mitsuba's pipeline) to 1e-5.
TEST(Spectrum, CornellBoxReflectances) {
    Sampled white = cbox_reflectance("white"), red = cbox_reflectance("red"), green = cbox_reflectance("green");
    ASSERT_EQ(white.w.size(), 76u);
    expect_rgb(spectrum_to_rgb(white.w, white.v), 0.8854f, 0.6989f, 0.6664f, 1e-3f, "white vs README");
    expect_rgb(spectrum_to_rgb(red.w, red.v), 0.5698f, 0.0428f, 0.0444f, 1e-3f, "red vs README");
    expect_rgb(spectrum_to_rgb(green.w, green.v), 0.1048f, 0.3784f, 0.0761f, 1e-3f, "green vs README");
    expect_rgb(spectrum_to_rgb(white.w, white.v), 0.885809f, 0.698859f, 0.666422f, 2e-5f, "white vs Mitsuba 3");
    expect_rgb(spectrum_to_rgb(red.w, red.v), 0.570068f, 0.0430135f, 0.0443706f, 2e-5f, "red vs Mitsuba 3");
    expect_rgb(spectrum_to_rgb(green.w, green.v), 0.105421f, 0.37798f, 0.076425f, 2e-5f, "green vs Mitsuba 3");
    // The exact integral reproduces the README rows to their 4 digits.
    expect_rgb(spectrum_to_rgb_exact(white.w, white.v), 0.8854f, 0.6989f, 0.6664f, 1e-4f, "white exact");
    expect_rgb(spectrum_to_rgb_exact(red.w, red.v), 0.5698f, 0.0428f, 0.0444f, 1e-4f, "red exact");
    expect_rgb(spectrum_to_rgb_exact(green.w, green.v), 0.1048f, 0.3784f, 0.0761f, 1e-4f, "green exact");
}

TEST(Spectrum, LuminaireReflectance) {
    Sampled light = parse_pairs("400:0.78, 500:0.78, 600:0.78, 700:0.78");
    expect_rgb(spectrum_to_rgb(light.w, light.v), 0.9359f, 0.7406f, 0.7049f, 1e-3f, "light vs README");
    expect_rgb(spectrum_to_rgb_exact(light.w, light.v), 0.9359f, 0.7406f, 0.7049f, 1e-4f, "light exact");
}

TEST(Spectrum, ConstantSpectrumScalesLinearly) {
    Sampled one = parse_pairs("400:1, 500:1, 600:1, 700:1");
    Sampled half = parse_pairs("400:0.5, 500:0.5, 600:0.5, 700:0.5");
    RGB a = spectrum_to_rgb(one.w, one.v), b = spectrum_to_rgb(half.w, half.v);
    expect_rgb(b, 0.5f * a.r, 0.5f * a.g, 0.5f * a.b, 2e-4f, "half");
    // Constant 1 over the whole CIE range: exactly the white point of the matrix, about (1.2, 0.95, 0.91)
    // because XYZ = (1.00007, 1, 1.00040) is equal-energy white, not D65.
    std::vector<float> w{360, 830}, v{1, 1};
    RGB e = spectrum_to_rgb_exact(w, v);
    EXPECT_NEAR(e.r, 1.2048f, 2e-3f);
    EXPECT_NEAR(e.g, 0.9484f, 2e-3f);
    EXPECT_NEAR(e.b, 0.9091f, 2e-3f);
}

TEST(Spectrum, RejectsBadSamples) {
    EXPECT_THROW(spectrum_to_rgb({500}, {1}), std::invalid_argument);
    EXPECT_THROW(spectrum_to_rgb({500, 400}, {1, 1}), std::invalid_argument);
    EXPECT_THROW(spectrum_to_rgb({400, 400}, {1, 1}), std::invalid_argument);
    EXPECT_THROW(spectrum_to_rgb({400, 500}, {1}), std::invalid_argument);
    EXPECT_THROW(spectrum_to_rgb_exact({400, 500}, {1, std::nanf("")}), std::invalid_argument);
}

TEST(Spectrum, SrgbRoundTrip) {
    for (int i = 0; i <= 1000; ++i) {
        float v = i / 1000.0f;
        EXPECT_NEAR(linear_to_srgb(srgb_to_linear(v)), v, 2e-6f) << v;
        EXPECT_NEAR(srgb_to_linear(linear_to_srgb(v)), v, 2e-6f) << v;
    }
    EXPECT_FLOAT_EQ(srgb_to_linear(0.0f), 0.0f);
    EXPECT_NEAR(srgb_to_linear(1.0f), 1.0f, 1e-6f);
    EXPECT_NEAR(srgb_to_linear(0.5f), 0.2140411f, 1e-6f);  // standard sRGB mid grey
    EXPECT_NEAR(linear_to_srgb(0.18f), 0.4613561f, 1e-6f);
    // The two branches meet continuously at the breakpoint.
    EXPECT_NEAR(srgb_to_linear(0.04045f), srgb_to_linear(0.0404501f), 1e-7f);
}

TEST(Spectrum, XyzToRgbMatrix) {
    // D65 white (x 0.3127, y 0.3290, Y 1) maps to RGB (1, 1, 1).
    RGB c = xyz_to_linear_srgb(0.950456f, 1.0f, 1.088754f);
    expect_rgb(c, 1.0f, 1.0f, 1.0f, 1e-3f, "D65");
}

TEST(Spectrum, CopperIsMitsubasDefaultConductor) {
    RGB eta, k;
    ASSERT_TRUE(conductor_ior("Cu", &eta, &k));
    expect_rgb(eta, 0.2004f, 0.9240f, 1.1022f, 5e-5f, "Cu eta");
    expect_rgb(k, 3.9129f, 2.4528f, 2.1422f, 5e-5f, "Cu k");
}

// The table entries are what the exact conversion of Mitsuba's data/ior files gives; check that the
// Cu entry really is that conversion (the data are Mitsuba's Cu.eta.spd / Cu.k.spd, luxpop.com).
TEST(Spectrum, CopperTableMatchesExactConversionOfMitsubaData) {
    const std::vector<float> w = {
        302.400421f, 306.133759f, 309.960449f, 313.884003f, 317.908142f, 322.036835f, 326.274139f, 330.624481f,
        335.092377f, 339.682678f, 344.400482f, 349.251221f, 354.240509f, 359.374420f, 364.659332f, 370.102020f,
        375.709625f, 381.489777f, 387.450562f, 393.600555f, 399.948975f, 406.505493f, 413.280579f, 420.285339f,
        427.531647f, 435.032196f, 442.800629f, 450.851562f, 459.200653f, 467.864838f, 476.862213f, 486.212463f,
        495.936707f, 506.057861f, 516.600769f, 527.592224f, 539.061646f, 551.040771f, 563.564453f, 576.670593f,
        590.400818f, 604.800842f, 619.920898f, 635.816284f, 652.548279f, 670.184753f, 688.800964f, 708.481018f,
        729.318665f, 751.419250f, 774.901123f, 799.897949f, 826.561157f, 855.063293f, 885.601257f};
    const std::vector<float> eta = {
        1.380000f, 1.358438f, 1.340000f, 1.329063f, 1.325000f, 1.332500f, 1.340000f, 1.334375f, 1.325000f,
        1.317812f, 1.310000f, 1.300313f, 1.290000f, 1.281563f, 1.270000f, 1.249062f, 1.225000f, 1.200000f,
        1.180000f, 1.174375f, 1.175000f, 1.177500f, 1.180000f, 1.178125f, 1.175000f, 1.172812f, 1.170000f,
        1.165312f, 1.160000f, 1.155312f, 1.150000f, 1.142812f, 1.135000f, 1.131562f, 1.120000f, 1.092437f,
        1.040000f, 0.950375f, 0.826000f, 0.645875f, 0.468000f, 0.351250f, 0.272000f, 0.230813f, 0.214000f,
        0.209250f, 0.213000f, 0.216250f, 0.223000f, 0.236500f, 0.250000f, 0.254188f, 0.260000f, 0.280000f,
        0.300000f};
    RGB table_eta, table_k;
    ASSERT_TRUE(conductor_ior("Cu", &table_eta, &table_k));
    expect_rgb(spectrum_to_rgb_exact(w, eta), table_eta.r, table_eta.g, table_eta.b, 2e-5f, "Cu eta");
}

TEST(Spectrum, NamedConductors) {
    RGB eta, k;
    for (const char* name : {"Ag", "Al", "Au", "Cr", "Cu", "W"}) {
        ASSERT_TRUE(conductor_ior(name, &eta, &k)) << name;
        EXPECT_GT(k.r, 1.0f) << name;  // metals: strongly absorbing in the visible
        EXPECT_GT(eta.r, 0.0f) << name;
    }
    ASSERT_TRUE(conductor_ior("Au", &eta, &k));
    EXPECT_LT(eta.r, eta.b);  // gold: red reflected more strongly than blue
    ASSERT_TRUE(conductor_ior("none", &eta, &k));
    expect_rgb(eta, 0, 0, 0, 0, "none eta");
    expect_rgb(k, 1, 1, 1, 0, "none k");
    EXPECT_FALSE(conductor_ior("Unobtainium", &eta, &k));
    EXPECT_FALSE(conductor_ior("cu", &eta, &k));  // Mitsuba's material names are file names: case matters
}

TEST(Spectrum, NamedDielectrics) {
    float ior = 0;
    ASSERT_TRUE(dielectric_ior("bk7", &ior));
    EXPECT_FLOAT_EQ(ior, 1.5046f);
    ASSERT_TRUE(dielectric_ior("air", &ior));
    EXPECT_FLOAT_EQ(ior, 1.00028f);
    ASSERT_TRUE(dielectric_ior("polypropylene", &ior));
    EXPECT_FLOAT_EQ(ior, 1.49f);
    ASSERT_TRUE(dielectric_ior("Water", &ior));
    EXPECT_FLOAT_EQ(ior, 1.333f);
    ASSERT_TRUE(dielectric_ior("diamond", &ior));
    EXPECT_FLOAT_EQ(ior, 2.419f);
    ASSERT_TRUE(dielectric_ior("vacuum", &ior));
    EXPECT_FLOAT_EQ(ior, 1.0f);
    for (const char* name : {"helium", "hydrogen", "carbon dioxide", "acetone", "ethanol", "carbon tetrachloride",
                             "glycerol", "benzene", "silicone oil", "bromine", "water ice", "fused quartz", "pyrex",
                             "acrylic glass", "sodium chloride", "amber", "pet"}) {
        ASSERT_TRUE(dielectric_ior(name, &ior)) << name;
        EXPECT_GT(ior, 1.0f) << name;
        EXPECT_LT(ior, 2.0f) << name;
    }
    EXPECT_FALSE(dielectric_ior("unobtainium", &ior));
}
