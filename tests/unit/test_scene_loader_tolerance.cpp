// Mitsuba's tolerance and iris's honesty (issue 47): what a published Mitsuba scene may carry that iris
// reads as Mitsuba does -- a parameter no plugin reads is a warning naming file:line (an error with
// SceneLoadOptions::strict), an unsupported plugin nothing refers to is a warning, an emitting shape
// without a BSDF is black (Mitsuba's Shape::configure), a medium as a shape's interior is one clear
// error, diffuseReflectance is diffuse's reflectance where reflectance is absent, and every colour form
// of Mitsuba 0.5 (<blackbody>, .spd files, hex, intent) with the two spectrum interpolations.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "formats/scene_xml.h"
#include "formats/serialized.h"
#include "libcommon/spectrum.h"
#include "support/temp_dir.h"

using namespace iris;
namespace fs = std::filesystem;

namespace {

using iris::test::TempDir;

int line_of(const std::string& text, const std::string& marker) {
    const size_t at = text.find(marker);
    EXPECT_NE(at, std::string::npos) << marker;
    return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

std::string scene_text(const std::string& body, const std::string& head = "") {
    return "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n" + head +
           "  <sensor type=\"perspective\">\n"
           "    <transform name=\"toWorld\"><lookAt origin=\"0, 0, -5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n"
           "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"16\"/><integer name=\"height\" value=\"16\"/></film>\n"
           "  </sensor>\n" +
           body + "</scene>\n";
}

Scene parse(const std::string& path, std::vector<std::string>* warnings, bool strict = false,
            SpectrumInterpolation interp = SpectrumInterpolation::Linear) {
    SceneLoadOptions o;
    o.warnings = warnings;
    o.strict = strict;
    o.spectrum_interpolation = interp;
    return parse_scene(path, o);
}

// The SceneError message of parse(path), or "" if it loads.
std::string error_of(const std::string& path, bool strict = false, std::vector<std::string>* warnings = nullptr) {
    std::vector<std::string> local;
    try {
        parse(path, warnings ? warnings : &local, strict);
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

// Whether one warning starts with "path:line:" and contains every fragment.
bool warned(const std::vector<std::string>& warnings, const std::string& path, int line,
            std::initializer_list<std::string> fragments) {
    const std::string where = path + ":" + std::to_string(line) + ": ";
    for (const std::string& w : warnings) {
        bool all = w.rfind(where, 0) == 0;
        for (const std::string& f : fragments) all = all && w.find(f) != std::string::npos;
        if (all) return true;
    }
    return false;
}

std::string joined(const std::vector<std::string>& v) {
    std::string s;
    for (const std::string& x : v) s += x + "\n";
    return s;
}

void expect_rgb(RGB c, RGB want, float rel, const std::string& what) {
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(c[i], want[i], rel * std::max(1e-6f, std::abs(want[i]))) << what << " channel " << i;
}

}  // namespace

// ---- unread parameters ---------------------------------------------------------------------------

// The published scenes' cases: alpha on a smooth conductor, faceNormals on a sphere, exponent on an
// area emitter, and the improved-path-guiding fork's usePathGuiding flag on BSDFs (with its <default>).
TEST(SceneTolerance, UnreadParameterWarnsNamingFileLinePluginAndParameter) {
    TempDir d;
    const std::string text = scene_text(R"(  <shape type="sphere">
    <boolean name="faceNormals" value="true"/>
    <bsdf type="conductor">
      <float name="alpha" value="0.2"/>
      <boolean name="usePathGuiding" value="$usePathGuiding"/>
    </bsdf>
    <emitter type="area"><rgb name="radiance" value="1"/><float name="exponent" value="3"/></emitter>
  </shape>
)", "  <default name=\"usePathGuiding\" value=\"true\"/>\n");
    const std::string path = d.write("s.xml", text);
    std::vector<std::string> w;
    const Scene s = parse(path, &w);
    EXPECT_EQ(s.spheres.size(), 1u);
    EXPECT_TRUE(warned(w, path, line_of(text, "faceNormals"), {"\"faceNormals\"", "shape \"sphere\""})) << joined(w);
    EXPECT_TRUE(warned(w, path, line_of(text, "\"alpha\""), {"\"alpha\"", "bsdf \"conductor\""})) << joined(w);
    EXPECT_TRUE(warned(w, path, line_of(text, "name=\"usePathGuiding\" value=\"$"), {"\"usePathGuiding\"", "bsdf \"conductor\""}))
        << joined(w);
    EXPECT_TRUE(warned(w, path, line_of(text, "exponent"), {"\"exponent\"", "emitter \"area\""})) << joined(w);
    EXPECT_EQ(w.size(), 4u) << joined(w);
    // --strict keeps the error, at the first unread parameter read (the nested BSDF is built first).
    const std::string e = error_of(path, true);
    EXPECT_EQ(e.rfind(path + ":" + std::to_string(line_of(text, "\"alpha\"")) + ":", 0), 0u) << e;
    EXPECT_NE(e.find("unknown parameter \"alpha\" for bsdf \"conductor\""), std::string::npos) << e;
}

// Mitsuba's schema allows <default> inside any plugin element (country_kitchen has one in a BSDF); the
// first one of a name wins, and the caller's value wins over all.
TEST(SceneTolerance, DefaultInsideAPluginElement) {
    TempDir d;
    const std::string text = scene_text(R"(  <shape type="sphere">
    <bsdf type="diffuse">
      <default name="refl" value="0.25"/>
      <float name="unused" value="$refl"/>
      <rgb name="reflectance" value="$refl"/>
    </bsdf>
  </shape>
)");
    const std::string path = d.write("s.xml", text);
    std::vector<std::string> w;
    EXPECT_EQ(parse(path, &w).bsdfs[0].diffuse.r, 0.25f);
    SceneLoadOptions o;
    o.warnings = &w;
    o.parameters["refl"] = "0.75";
    EXPECT_EQ(parse_scene(path, o).bsdfs[0].diffuse.r, 0.75f);
}

// A misspelt name leaves the default in place, with the warning saying which parameter was ignored.
TEST(SceneTolerance, MisspeltParameterKeepsTheDefault) {
    TempDir d;
    const std::string text = scene_text(R"(  <shape type="sphere">
    <bsdf type="diffuse"><rgb name="reflectanse" value="0.9"/></bsdf>
  </shape>
)");
    const std::string path = d.write("s.xml", text);
    std::vector<std::string> w;
    const Scene s = parse(path, &w);
    ASSERT_EQ(s.bsdfs.size(), 1u);
    EXPECT_EQ(s.bsdfs[0].diffuse.r, 0.5f);
    EXPECT_TRUE(warned(w, path, line_of(text, "reflectanse"), {"\"reflectanse\"", "bsdf \"diffuse\"", "--strict"})) << joined(w);
}

// ---- plugins iris cannot build ---------------------------------------------------------------------

TEST(SceneTolerance, UnreferencedUnsupportedPluginWarnsReferencedFails) {
    TempDir d;
    const std::string head = R"(  <bsdf type="velvet" id="cloth"><float name="sheen" value="1"/></bsdf>
  <texture type="wireframe" id="wires"/>
  <bsdf type="velvet"/>
)";
    const std::string text = scene_text("  <shape type=\"sphere\"/>\n", head);
    const std::string path = d.write("s.xml", text);
    std::vector<std::string> w;
    EXPECT_NO_THROW(parse(path, &w));
    EXPECT_TRUE(warned(w, path, line_of(text, "id=\"cloth\""), {"unsupported plugin \"velvet\"", "\"cloth\""})) << joined(w);
    EXPECT_TRUE(warned(w, path, line_of(text, "wireframe"), {"unsupported plugin \"wireframe\"", "texture"})) << joined(w);
    EXPECT_TRUE(warned(w, path, line_of(text, "<bsdf type=\"velvet\"/>"), {"unsupported plugin \"velvet\""})) << joined(w);

    // Referenced by a shape: an error at the reference, naming the plugin and where it was declared.
    const std::string used = scene_text("  <shape type=\"sphere\">\n    <ref id=\"cloth\"/>\n  </shape>\n", head);
    const std::string up = d.write("used.xml", used);
    const std::string e = error_of(up);
    EXPECT_EQ(e.rfind(up + ":" + std::to_string(line_of(used, "<ref id=\"cloth\"")) + ":", 0), 0u) << e;
    EXPECT_NE(e.find("unsupported plugin \"velvet\""), std::string::npos) << e;
    EXPECT_NE(e.find(up + ":" + std::to_string(line_of(used, "id=\"cloth\">"))), std::string::npos) << e;
    // A texture referenced by a BSDF parameter: the same.
    const std::string tex = scene_text(
        "  <shape type=\"sphere\">\n    <bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"wires\"/></bsdf>\n  </shape>\n", head);
    const std::string tp = d.write("tex.xml", tex);
    const std::string te = error_of(tp);
    EXPECT_EQ(te.rfind(tp + ":" + std::to_string(line_of(tex, "<ref name=\"reflectance\"")) + ":", 0), 0u) << te;
    EXPECT_NE(te.find("unsupported plugin \"wireframe\""), std::string::npos) << te;
    // Inline in a shape it stays an error (SceneLoaderErrors.UnknownPlugin has the line).
    const std::string inl = d.write("inline.xml", scene_text("  <shape type=\"sphere\"><bsdf type=\"velvet\"/></shape>\n"));
    EXPECT_NE(error_of(inl).find("unsupported plugin \"velvet\" (bsdf)"), std::string::npos);
}

// ---- Shape::configure's no-BSDF rules ----------------------------------------------------------------

TEST(SceneTolerance, EmitterWithoutBsdfIsBlackOtherShapesDiffuseHalf) {
    TempDir d;
    const std::string text = scene_text(R"(  <shape type="sphere" id="lamp">
    <emitter type="area"><rgb name="radiance" value="1"/></emitter>
  </shape>
  <shape type="sphere" id="plain"><point name="center" x="3" y="0" z="0"/></shape>
  <shape type="sphere" id="lit">
    <point name="center" x="-3" y="0" z="0"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.25"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter>
  </shape>
)");
    std::vector<std::string> w;
    const Scene s = parse(d.write("s.xml", text), &w);
    ASSERT_EQ(s.spheres.size(), 3u);
    const RGB lamp = s.bsdfs[s.spheres[0].bsdf].diffuse, plain = s.bsdfs[s.spheres[1].bsdf].diffuse,
              lit = s.bsdfs[s.spheres[2].bsdf].diffuse;
    EXPECT_EQ(s.bsdfs[s.spheres[0].bsdf].type, BsdfType::Diffuse);
    EXPECT_EQ(lamp.r + lamp.g + lamp.b, 0.0f) << "an emitter without a BSDF absorbs everything (Mitsuba)";
    EXPECT_EQ(plain.r, 0.5f);
    EXPECT_EQ(lit.r, 0.25f) << "an emitter's own BSDF is kept";
}

// ---- media -------------------------------------------------------------------------------------------

TEST(SceneTolerance, MediumAsInteriorNamesTheMedium) {
    TempDir d;
    const std::string text = scene_text(R"(  <medium type="homogeneous" id="milk"/>
  <shape type="sphere">
    <bsdf type="dielectric"/>
    <ref name="interior" id="milk"/>
  </shape>
)");
    const std::string path = d.write("s.xml", text);
    std::vector<std::string> w;
    const std::string e = error_of(path, false, &w);
    EXPECT_EQ(e.rfind(path + ":" + std::to_string(line_of(text, "name=\"interior\"")) + ":", 0), 0u) << e;
    EXPECT_NE(e.find("medium \"milk\""), std::string::npos) << e;
    EXPECT_NE(e.find("participating media are not supported yet"), std::string::npos) << e;
    EXPECT_TRUE(w.empty()) << "no warning may say that nothing refers to the medium: " << joined(w);
    // Unreferenced, it is still a warning (at the end of the scene).
    const std::string alone = scene_text("  <medium type=\"homogeneous\" id=\"milk\"/>\n  <shape type=\"sphere\"/>\n");
    const std::string ap = d.write("alone.xml", alone);
    EXPECT_NO_THROW(parse(ap, &w));
    EXPECT_TRUE(warned(w, ap, line_of(alone, "milk"), {"medium \"milk\" ignored"})) << joined(w);
}

// ---- diffuseReflectance -------------------------------------------------------------------------------

TEST(SceneTolerance, DiffuseReflectanceIsTheAliasOfReflectance) {
    TempDir d;
    const std::string text = scene_text(R"(  <shape type="sphere"><bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.1, 0.2, 0.3"/></bsdf></shape>
  <shape type="sphere"><bsdf type="roughdiffuse"><rgb name="diffuseReflectance" value="0.3"/></bsdf></shape>
  <shape type="sphere"><bsdf type="diffuse">
    <rgb name="reflectance" value="0.7"/>
    <rgb name="diffuseReflectance" value="0.2"/>
  </bsdf></shape>
)");
    const std::string path = d.write("s.xml", text);
    std::vector<std::string> w;
    const Scene s = parse(path, &w);
    ASSERT_EQ(s.bsdfs.size(), 3u);
    expect_rgb(s.bsdfs[0].diffuse, RGB(0.1f, 0.2f, 0.3f), 0, "diffuse");
    expect_rgb(s.bsdfs[1].diffuse, RGB(0.3f), 0, "roughdiffuse");
    // Both given: reflectance wins (as in Mitsuba) and the other is an unread parameter.
    expect_rgb(s.bsdfs[2].diffuse, RGB(0.7f), 0, "both");
    EXPECT_TRUE(warned(w, path, line_of(text, "value=\"0.2\"/>"), {"\"diffuseReflectance\""})) << joined(w);
}

// ---- serialized version 3 ------------------------------------------------------------------------------

TEST(SceneTolerance, SerializedVersion3IsSinglePrecision) {
    TempDir d;
    TriangleMesh m;
    m.positions = {Vec3(-1, -1, 0), Vec3(1, -1, 0), Vec3(1, 1, 0), Vec3(-1, 1, 0)};
    m.indices = {0, 1, 2, 0, 2, 3};
    const std::string shape = serialize_shape(m, "", false, 3);
    ASSERT_EQ(uint8_t(shape[2]), 3u);  // the version field
    d.write("v3.serialized", shape + serialized_dictionary({shape.size()}, 3));
    const std::string text = scene_text(R"(  <shape type="serialized"><string name="filename" value="v3.serialized"/></shape>
)");
    std::vector<std::string> w;
    const Scene s = parse(d.write("s.xml", text), &w);
    ASSERT_EQ(s.meshes.size(), 1u);
    ASSERT_EQ(s.meshes[0].positions.size(), 4u);
    EXPECT_EQ(s.meshes[0].positions[2].x, 1.0f);
    EXPECT_EQ(s.meshes[0].positions[2].y, 1.0f);
    // Decoded directly too (and a two-shape v3 file's 32-bit dictionary).
    const TriangleMesh two = parse_serialized(shape + shape + serialized_dictionary({shape.size(), shape.size()}, 3), 1, "two");
    EXPECT_EQ(two.indices, m.indices);
}

// ---- colours and spectra ---------------------------------------------------------------------------------

// Planck's law integrated by Mitsuba's rule equals the exact integral of the same curve sampled at 1 nm
// (the quadrature's tolerance is 1e-4), and Mitsuba's units: at 6500 K the luminance is ~4.3e4.
TEST(SceneTolerance, BlackbodyIsPlanckAgainstTheCieTables) {
    for (float kelvin : {2700.0f, 6500.0f}) {
        std::vector<float> wl, v;
        for (int nm = 360; nm <= 830; ++nm) {
            const double l = nm * 1e-9, h = 6.62606957e-34, c = 299792458.0, k = 1.3806488e-23;
            wl.push_back(float(nm));
            v.push_back(float(2 * h * c * c / std::pow(l, 5) / (std::exp(h * c / (l * k * kelvin)) - 1) * 1e-9));
        }
        const RGB want = spectrum_to_rgb_exact(wl, v), got = blackbody_to_rgb(kelvin, SpectrumInterpolation::Linear);
        expect_rgb(got, want, 2e-3f, "blackbody " + std::to_string(kelvin));
    }
    const RGB d65ish = blackbody_to_rgb(6500, SpectrumInterpolation::Linear);
    const float y = 0.2126f * d65ish.r + 0.7152f * d65ish.g + 0.0722f * d65ish.b;
    EXPECT_NEAR(y, 4.3e4f, 0.1e4f);
    EXPECT_THROW(blackbody_to_rgb(-5, SpectrumInterpolation::Linear), std::invalid_argument);
}

TEST(SceneTolerance, EveryColourFormOfMitsuba) {
    TempDir d;
    d.write("red.spd", "# a test spectrum\n\n600 1.5\n700 2.0\n");
    const std::string text = scene_text(R"(  <shape type="sphere">
    <emitter type="area"><blackbody name="radiance" temperature="6500K" scale="1e-4"/></emitter>
  </shape>
  <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="#ff8000" intent="reflectance"/></bsdf></shape>
  <shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="0.25" intent="illuminant"/></bsdf></shape>
  <shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="red.spd"/></bsdf></shape>
  <shape type="sphere"><bsdf type="diffuse"><srgb name="reflectance" value="#808080"/></bsdf></shape>
)");
    std::vector<std::string> w;
    const Scene s = parse(d.write("s.xml", text), &w);
    ASSERT_EQ(s.lights.size(), 1u);
    expect_rgb(s.lights[0].radiance, blackbody_to_rgb(6500, SpectrumInterpolation::Linear) * 1e-4f, 1e-6f, "blackbody");
    expect_rgb(s.bsdfs[s.spheres[1].bsdf].diffuse, RGB(1.0f, 128.0f / 255.0f, 0.0f), 0, "<rgb> #ff8000 (linear bytes)");
    expect_rgb(s.bsdfs[s.spheres[2].bsdf].diffuse, RGB(0.25f), 0, "<spectrum> with intent");
    expect_rgb(s.bsdfs[s.spheres[3].bsdf].diffuse,
               spectrum_to_rgb({600, 700}, {1.5f, 2.0f}, SpectrumInterpolation::Linear), 0, ".spd file");
    expect_rgb(s.bsdfs[s.spheres[4].bsdf].diffuse, RGB(srgb_to_linear(128.0f / 255.0f)), 0, "<srgb> hex");

    // One-line refusals, each at its line.
    const std::pair<const char*, const char*> bad[] = {
        {"<blackbody name=\"reflectance\" temperature=\"-300\"/>", "temperature must be positive"},
        {"<blackbody name=\"reflectance\" temperature=\"3000\" scale=\"-1\"/>", "scale must not be negative"},
        {"<rgb name=\"reflectance\" value=\"0.5\" intent=\"glow\"/>", "intent must be reflectance or illuminant"},
        {"<spectrum name=\"reflectance\" value=\"400:1, 500:1\" intent=\"reflectance\"/>", "intent is for a single value"},
        {"<spectrum name=\"reflectance\" filename=\"missing.spd\"/>", "cannot read spectrum file"},
        {"<spectrum name=\"reflectance\" value=\"1\" filename=\"red.spd\"/>", "either value or filename"},
        {"<hsv name=\"reflectance\" value=\"1, 1, 1\"/>", "unknown element <hsv>"},
    };
    for (const auto& [element, message] : bad) {
        const std::string t = scene_text(std::string("  <shape type=\"sphere\"><bsdf type=\"diffuse\">\n    ") + element +
                                         "\n  </bsdf></shape>\n");
        const std::string p = d.write("bad.xml", t);
        const std::string e = error_of(p);
        EXPECT_EQ(e.rfind(p + ":" + std::to_string(line_of(t, element)) + ":", 0), 0u) << element << ": " << e;
        EXPECT_NE(e.find(message), std::string::npos) << element << ": " << e;
    }
}

// spectrum-interpolation: the corrected interpolation is the exact integral of the zero-extended curve
// (to the quadrature's tolerance); Mitsuba 0.5.0's reproduces the thesis's measured emitter (the
// README's 18.387, 10.987, 2.754); the loader applies the option, and it is part of the fingerprint only
// where a spectrum depends on it.
TEST(SceneTolerance, SpectrumInterpolationLinearOrMitsuba050) {
    const std::vector<float> w = {400, 500, 600, 700}, v = {0, 8, 15.6f, 18.4f};
    const std::vector<float> we = {400, 500, 600, 700, 800}, ve = {0, 8, 15.6f, 18.4f, 0};  // zero-extended
    const RGB lin = spectrum_to_rgb(w, v, SpectrumInterpolation::Linear);
    const RGB old = spectrum_to_rgb(w, v, SpectrumInterpolation::Mitsuba050);
    expect_rgb(lin, spectrum_to_rgb_exact(we, ve), 2e-3f, "linear = exact");
    expect_rgb(old, RGB(18.387f, 10.987f, 2.754f), 3e-4f, "mitsuba-0.5.0 = the thesis's measurement (5 digits)");
    EXPECT_GT(std::abs(lin.r - old.r), 0.05f * old.r) << "the two differ (red by ~13 %)";

    TempDir d;
    const std::string spectral = d.write("spectral.xml", scene_text(R"(  <shape type="sphere">
    <emitter type="area"><spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/></emitter>
  </shape>
)"));
    const std::string plain = d.write("plain.xml", scene_text("  <shape type=\"sphere\"/>\n"));
    std::vector<std::string> warnings;
    const Scene a = parse(spectral, &warnings, false, SpectrumInterpolation::Linear);
    const Scene b = parse(spectral, &warnings, false, SpectrumInterpolation::Mitsuba050);
    expect_rgb(a.lights[0].radiance, lin, 0, "loader, linear");
    expect_rgb(b.lights[0].radiance, old, 0, "loader, mitsuba-0.5.0");
    EXPECT_NE(a.fingerprint, b.fingerprint);
    EXPECT_EQ(parse(plain, &warnings, false, SpectrumInterpolation::Linear).fingerprint,
              parse(plain, &warnings, false, SpectrumInterpolation::Mitsuba050).fingerprint);
    SceneLoadOptions defaults;
    EXPECT_EQ(defaults.spectrum_interpolation, SpectrumInterpolation::Linear) << "the documented default";
}
