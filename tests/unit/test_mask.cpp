// Mitsuba's `mask` BSDF: the reader (opacity as a spectrum or a texture, Mitsuba's default 0.5 and its
// rescaling above 1, the nested BSDF, and each refusal in one line), and the Embree filter that makes a
// masked surface let rays through: deterministic where the opacity is 0 or 1 (which half of a textured
// quad stops rays, in Mitsuba's uv convention, for closest-hit and occlusion rays, on a mesh and on a
// sphere), no filter at all on a scene without masks, and the filter's number the same for the same
// ray. The statistics (the filter's numbers are uniform; a mask halves the irradiance behind it for
// light samples, BSDF samples and photons alike) are in tests/statistical/test_mask_irradiance.cpp.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "formats/png.h"
#include "formats/scene_xml.h"
#include "libcommon/accel.h"
#include "libcommon/scene.h"
#include "support/temp_dir.h"

namespace fs = std::filesystem;

namespace iris {
namespace {

using iris::test::TempDir;

std::string scene_text(const std::string& body) {
    return "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
           "  <sensor type=\"perspective\">\n    <float name=\"fov\" value=\"30\"/>\n"
           "    <transform name=\"toWorld\"><lookAt origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n"
           "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film>\n"
           "  </sensor>\n" +
           body + "</scene>\n";
}

int line_of(const std::string& text, const std::string& marker) {
    const size_t at = text.find(marker);
    EXPECT_NE(at, std::string::npos) << marker;
    return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

Scene parse(const std::string& path, std::vector<std::string>* warnings = nullptr) {
    std::vector<std::string> local;
    SceneLoadOptions o;
    o.warnings = warnings ? warnings : &local;
    return parse_scene(path, o);
}
Scene load(const std::string& path) {
    std::vector<std::string> local;
    SceneLoadOptions o;
    o.warnings = &local;
    return load_scene(path, o);
}

// The loader's message for `text` (written to DIR/name), which must fail.
std::string error_of(const TempDir& d, const std::string& text) {
    const std::string path = d.write("bad.xml", text);
    try {
        parse(path);
    } catch (const std::exception& e) {
        return e.what();
    }
    ADD_FAILURE() << "loaded without an error:\n" << text;
    return "";
}

void expect_error(const TempDir& d, const std::string& text, const std::string& marker, const std::string& what) {
    const std::string msg = error_of(d, text);
    EXPECT_NE(msg.find("bad.xml:" + std::to_string(line_of(text, marker)) + ":"), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
}

// A 2 x 1 PNG: the left texel black (transparent), the right white (opaque).
void write_half_mask(const std::string& path) { write_png(path, 2, 1, {0, 0, 0, 1, 1, 1}); }

// kitchen.xml's Blinds (PPG), as published: a grey rgb opacity over a twosided diffuse.
TEST(MaskReader, KitchenBlindsForm) {
    TempDir d;
    const std::string text = scene_text(R"(  <bsdf type="mask" id="Blinds">
    <rgb name="opacity" value="0.612066, 0.612066, 0.612066"/>
    <bsdf type="twosided">
      <bsdf type="diffuse">
        <rgb name="reflectance" value="0.612066, 0.499505, 0.378676"/>
      </bsdf>
    </bsdf>
  </bsdf>
  <shape type="rectangle"><ref id="Blinds"/></shape>
  <shape type="sphere"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></shape>
  <shape type="sphere"><bsdf type="mask"><spectrum name="opacity" value="1"/><bsdf type="roughconductor"/></bsdf></shape>
)");
    const Scene s = parse(d.write("blinds.xml", text));
    const Bsdf& b = s.bsdfs[s.meshes[0].bsdf];
    EXPECT_EQ(b.type, BsdfType::Diffuse);
    EXPECT_TRUE(b.two_sided);
    EXPECT_NEAR(b.opacity, 0.612066f, 1e-5f);
    EXPECT_EQ(b.tex_opacity, -1);
    EXPECT_NEAR(b.diffuse.b, 0.378676f, 1e-5f);
    EXPECT_TRUE(bsdf_is_masked(b));
    // Mitsuba's default opacity is 0.5; opacity 1 is an opaque surface (no filter needed).
    EXPECT_FLOAT_EQ(s.bsdfs[s.spheres[0].bsdf].opacity, 0.5f);
    EXPECT_FALSE(bsdf_is_masked(s.bsdfs[s.spheres[1].bsdf]));
    EXPECT_EQ(s.bsdfs[s.spheres[1].bsdf].type, BsdfType::RoughConductor);
}

// bathroom.xml's Rug (improved-path-guiding), as published: a bitmap opacity over a twosided diffuse
// with a textured reflectance; and the same through <ref>s to a top-level texture and BSDF.
TEST(MaskReader, BathroomRugFormAndRefs) {
    TempDir d;
    write_half_mask(d.file("rug_mask.png"));
    write_png(d.file("rug.png"), 1, 1, {0.5f, 0.4f, 0.3f});
    const std::string text = scene_text(R"(  <bsdf type="mask" id="Rug">
    <texture name="opacity" type="bitmap">
      <string name="filename" value="rug_mask.png"/>
      <string name="filterType" value="trilinear"/>
    </texture>
    <bsdf type="twosided">
      <bsdf type="diffuse">
        <texture name="reflectance" type="bitmap">
          <string name="filename" value="rug.png"/>
          <string name="filterType" value="trilinear"/>
        </texture>
      </bsdf>
    </bsdf>
  </bsdf>
  <texture type="bitmap" id="holes"><string name="filename" value="rug_mask.png"/></texture>
  <bsdf type="roughplastic" id="inner"/>
  <shape type="rectangle"><ref id="Rug"/></shape>
  <shape type="rectangle"><bsdf type="mask"><ref name="opacity" id="holes"/><ref id="inner"/></bsdf></shape>
)");
    std::vector<std::string> warnings;
    const Scene s = parse(d.write("rug.xml", text), &warnings);
    const Bsdf& rug = s.bsdfs[s.meshes[0].bsdf];
    EXPECT_GE(rug.tex_opacity, 0);
    EXPECT_FLOAT_EQ(rug.opacity, 1.0f);
    EXPECT_TRUE(rug.two_sided);
    EXPECT_GE(rug.tex_diffuse, 0);
    EXPECT_NE(rug.tex_diffuse, rug.tex_opacity);
    const Bsdf& other = s.bsdfs[s.meshes[1].bsdf];
    EXPECT_EQ(other.type, BsdfType::RoughPlastic);
    EXPECT_GE(other.tex_opacity, 0);
    // The opacity alone does not make the BSDF textured: shading never reads it (the filter does).
    EXPECT_FALSE(bsdf_has_textured_params(other));
    const Texture& t = s.textures[size_t(other.tex_opacity)];
    ASSERT_EQ(t.texels.size(), 2u);
    EXPECT_FLOAT_EQ(t.texels[0].r, 0.0f);
    EXPECT_FLOAT_EQ(t.texels[1].r, 1.0f);
}

// As Mitsuba's ensureEnergyConservation: an opacity above 1 is scaled by 0.99 / its maximum, with a
// warning naming the line; a mask inside a mask multiplies constant opacities; an all but grey opacity is
// read as its luminance.
TEST(MaskReader, RescalingAndNesting) {
    TempDir d;
    const std::string text = scene_text(R"(  <shape type="sphere">
    <bsdf type="mask">
      <spectrum name="opacity" value="2"/>
      <bsdf type="diffuse"/>
    </bsdf>
  </shape>
  <shape type="sphere">
    <bsdf type="mask">
      <spectrum name="opacity" value="0.5"/>
      <bsdf type="mask"><spectrum name="opacity" value="0.6"/><bsdf type="diffuse"/></bsdf>
    </bsdf>
  </shape>
  <shape type="sphere">
    <bsdf type="mask"><rgb name="opacity" value="0.5, 0.505, 0.5"/><bsdf type="diffuse"/></bsdf>
  </shape>
)");
    std::vector<std::string> warnings;
    const Scene s = parse(d.write("scaled.xml", text), &warnings);
    EXPECT_NEAR(s.bsdfs[s.spheres[0].bsdf].opacity, 0.99f, 1e-6f);
    std::erase_if(warnings, [](const std::string& w) { return w.find("mask:") == std::string::npos; });  // (no emitters)
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("opacity reaches 2 (> 1): scaled by 0.495"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("scaled.xml:" + std::to_string(line_of(text, "\"2\"")) + ":"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("ensureEnergyConservation"), std::string::npos) << warnings[0];
    EXPECT_NEAR(s.bsdfs[s.spheres[1].bsdf].opacity, 0.3f, 1e-6f);
    // Grey within 0.01 (a JPEG's chroma noise): read as its luminance.
    EXPECT_NEAR(s.bsdfs[s.spheres[2].bsdf].opacity, 0.5f + 0.715160f * 0.005f, 1e-5f);
}

TEST(MaskReader, RefusalsAreOneLineNamingTheLine) {
    TempDir d;
    write_half_mask(d.file("m.png"));
    write_png(d.file("colour.png"), 1, 1, {1, 0, 0});
    auto shape = [](const std::string& bsdf) { return scene_text("  <shape type=\"sphere\">\n" + bsdf + "  </shape>\n"); };
    std::string t = shape("    <bsdf type=\"mask\">\n      <spectrum name=\"opacity\" value=\"0.3\"/>\n    </bsdf>\n");
    expect_error(d, t, "\"mask\"", "mask needs a nested <bsdf> or <ref>");
    t = shape("    <bsdf type=\"mask\">\n      <rgb name=\"opacity\" value=\"0.2, 0.5, 0.5\"/>\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n");
    expect_error(d, t, "<rgb", "a coloured opacity is not supported");
    t = shape("    <bsdf type=\"mask\">\n      <texture name=\"opacity\" type=\"bitmap\">\n"
              "        <string name=\"filename\" value=\"colour.png\"/>\n      </texture>\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n");
    expect_error(d, t, "<texture", "a coloured opacity is not supported");
    t = shape("    <bsdf type=\"mask\">\n      <spectrum name=\"opacity\" value=\"-0.5\"/>\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n");
    expect_error(d, t, "-0.5", "opacity must be finite and non-negative");
    t = shape("    <bsdf type=\"mask\">\n      <bsdf type=\"diffuse\"/>\n      <bsdf type=\"plastic\"/>\n    </bsdf>\n");
    expect_error(d, t, "plastic", "mask takes exactly one nested <bsdf> or <ref>");
    t = shape("    <bsdf type=\"mask\">\n      <texture name=\"reflectance\" type=\"checkerboard\"/>\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n");
    expect_error(d, t, "checkerboard", "only opacity can be a texture");
    t = shape("    <bsdf type=\"mask\">\n      <texture name=\"opacity\" type=\"checkerboard\"/>\n"
              "      <spectrum name=\"opacity\" value=\"0.5\"/>\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n");
    expect_error(d, t, "<spectrum", "parameter \"opacity\" given twice");
    t = shape("    <bsdf type=\"mask\">\n      <texture name=\"opacity\" type=\"checkerboard\"/>\n"
              "      <bsdf type=\"mask\"><spectrum name=\"opacity\" value=\"0.5\"/><bsdf type=\"diffuse\"/></bsdf>\n    </bsdf>\n");
    expect_error(d, t, "\"mask\"", "a mask inside a mask is supported only with constant opacities");
    t = shape("    <bsdf type=\"mask\">\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n"
              "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter>\n");
    expect_error(d, t, "<emitter", "an area emitter on a shape whose bsdf is a mask is not supported");
    t = shape("    <bsdf type=\"mask\">\n      <bsdf type=\"diffuse\"/>\n      <shape type=\"sphere\"/>\n    </bsdf>\n");
    expect_error(d, t, "<shape type=\"sphere\"/>", "<shape> is not allowed inside bsdf \"mask\"");
}

// A ray along -z from (x, y, 5) through the scene, closest hit and occlusion.
struct Probe {
    bool hit, occluded;
};
Probe probe(const Scene& s, float x, float y) {
    Ray r;
    r.o = Vec3(x, y, 5);
    r.d = Vec3(0, 0, -1);
    SurfaceHit h;
    return {s.intersect(r, &h), s.occluded(r)};
}

// The 2 x 1 half mask on a rectangle (Mitsuba's rectangle: [-1, 1]^2 in z = 0, uv = ((x + 1) / 2,
// (y + 1) / 2)): rays through its left half (u < 1/2, opacity 0) pass, rays through its
// right half stop, whatever the ray type; the same on a sphere, whose u = phi / 2 pi (phi from +x
// towards +y) is below 1/2 where y > 0.
TEST(MaskFilter, TexturedOpacityZeroAndOneIsExact) {
    TempDir d;
    write_half_mask(d.file("m.png"));
    const std::string mask = R"(<bsdf type="mask">
      <texture name="opacity" type="bitmap"><string name="filename" value="m.png"/><string name="filterType" value="nearest"/></texture>
      <bsdf type="diffuse"/>
    </bsdf>)";
    Scene s = load(d.write("quad.xml", scene_text("  <shape type=\"rectangle\">\n    " + mask + "\n  </shape>\n")));
    ASSERT_EQ(s.accel->masked_shapes(), 1u);
    for (float y : {-0.7f, 0.1f, 0.8f}) {
        for (float x : {-0.9f, -0.5f, -0.1f}) {
            const Probe p = probe(s, x, y);
            EXPECT_FALSE(p.hit || p.occluded) << "transparent half at " << x << ", " << y;
        }
        for (float x : {0.1f, 0.5f, 0.9f}) {
            const Probe p = probe(s, x, y);
            EXPECT_TRUE(p.hit && p.occluded) << "opaque half at " << x << ", " << y;
        }
    }
    // From behind, too (the filter does not care about the side).
    Ray back;
    back.o = Vec3(-0.5f, 0, -5);
    back.d = Vec3(0, 0, 1);
    SurfaceHit h;
    EXPECT_FALSE(s.intersect(back, &h));
    back.o.x = 0.5f;
    EXPECT_TRUE(s.intersect(back, &h));

    Scene sp = load(d.write("sphere.xml", scene_text("  <shape type=\"sphere\">\n    " + mask + "\n  </shape>\n")));
    // y > 0: u < 1/2, transparent both where the ray enters and leaves: the ray passes the whole sphere.
    EXPECT_FALSE(probe(sp, 0.2f, 0.5f).hit);
    EXPECT_FALSE(probe(sp, 0.2f, 0.5f).occluded);
    const Probe below = probe(sp, 0.2f, -0.5f);
    EXPECT_TRUE(below.hit && below.occluded);
    Ray r;
    r.o = Vec3(0.2f, -0.5f, 5);
    r.d = Vec3(0, 0, -1);
    ASSERT_TRUE(sp.intersect(r, &h));
    EXPECT_GT(h.p.z, 0) << "the near side stops it";
}

// The filter's number is a function of the ray and the primitive: the same ray gets the same answer
// each time (so does the image, for any thread count), the two sides of a sphere and two primitives
// get their own.
TEST(MaskFilter, SameRaySameAnswer) {
    const Vec3 o(0.1f, 0.2f, 0.3f), d = normalize(Vec3(1, 2, 3));
    const float a = mask_uniform(o, d, 3, 7, false);
    EXPECT_EQ(a, mask_uniform(o, d, 3, 7, false));
    EXPECT_NE(a, mask_uniform(o, d, 3, 7, true));
    EXPECT_NE(a, mask_uniform(o, d, 3, 8, false));
    EXPECT_NE(a, mask_uniform(o, d, 4, 7, false));
    EXPECT_NE(a, mask_uniform(Vec3(0.1f, 0.2f, std::nextafter(0.3f, 1.0f)), d, 3, 7, false));
    EXPECT_GE(a, 0.0f);
    EXPECT_LT(a, 1.0f);
}

// A scene without masks installs no filter: its rays trace as before masks existed. An opacity of 1
// installs none either; opacity 0 hides the surface from every ray.
TEST(MaskFilter, OnlyMaskedShapesCarryTheFilter) {
    TempDir d;
    const Scene plain = load(d.write("plain.xml", scene_text("  <shape type=\"rectangle\"><bsdf type=\"diffuse\"/></shape>\n"
                                                            "  <shape type=\"sphere\"><bsdf type=\"mask\"><spectrum name=\"opacity\" "
                                                            "value=\"1\"/><bsdf type=\"diffuse\"/></bsdf></shape>\n")));
    EXPECT_EQ(plain.accel->masked_shapes(), 0u);
    const Scene zero = load(d.write("zero.xml", scene_text("  <shape type=\"rectangle\"><bsdf type=\"mask\"><spectrum name=\"opacity\" "
                                                           "value=\"0\"/><bsdf type=\"diffuse\"/></bsdf></shape>\n")));
    EXPECT_EQ(zero.accel->masked_shapes(), 1u);
    for (float x : {-0.5f, 0.0f, 0.5f}) {
        const Probe p = probe(zero, x, 0.3f);
        EXPECT_FALSE(p.hit || p.occluded);
    }
}

}  // namespace
}  // namespace iris
