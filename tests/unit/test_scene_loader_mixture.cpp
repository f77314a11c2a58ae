// The Mitsuba reader's phong, mixturebsdf and blendbsdf (formats/mitsuba/bsdfs.cpp): parameters,
// Mitsuba 0.5's defaults, energy conservation, the parts linked by Scene::finalize, textured parts
// resolved per hit, and what is refused (each error on the element's line).
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "formats/scene_xml.h"
#include "libcommon/scene.h"

namespace iris {
namespace {

namespace fs = std::filesystem;

struct Dir {
    fs::path path;
    Dir() {
        static std::atomic<int> n{0};
        path = fs::temp_directory_path() / ("iris_mixture_" + std::to_string(::getpid()) + "_" + std::to_string(n++));
        fs::create_directories(path);
    }
    ~Dir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
    std::string write(const std::string& text) const {
        const fs::path p = path / "s.xml";
        std::ofstream(p) << text;
        return p.string();
    }
};

// A scene whose one sphere carries `bsdf` (lines 1-2 are the header: the BSDF starts on line 4).
std::string scene(const std::string& bsdf, const std::string& before = "") {
    return "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n" + before + "<shape type=\"sphere\">\n" + bsdf +
           "\n</shape>\n<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/>"
           "<integer name=\"height\" value=\"4\"/></film></sensor>\n</scene>\n";
}
// Loads the scene; *warnings gets the warnings about BSDFs only (the small scene draws others: no light).
Scene load(const std::string& text, std::vector<std::string>* warnings = nullptr) {
    Dir d;
    std::vector<std::string> all;
    SceneLoadOptions o;
    o.warnings = &all;
    Scene s = load_scene(d.write(text), o);
    if (warnings)
        for (const std::string& w : all)
            if (w.find("phong") != std::string::npos || w.find("mixturebsdf") != std::string::npos ||
                w.find("blendbsdf") != std::string::npos)
                warnings->push_back(w);
    return s;
}
void expect_error(const std::string& text, int line, const std::string& fragment) {
    Dir d;
    const std::string path = d.write(text);
    try {
        std::vector<std::string> w;
        SceneLoadOptions o;
        o.warnings = &w;
        load_scene(path, o);
        ADD_FAILURE() << "no error; expected: " << fragment;
    } catch (const SceneError& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind(path + ":" + std::to_string(line) + ":", 0), 0u) << msg;
        EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
    }
}
const Bsdf& sphere_bsdf(const Scene& s) { return s.bsdfs[s.spheres.at(0).bsdf]; }

TEST(LoaderPhong, ParametersAndMitsubaDefaults) {
    const Scene d = load(scene("<bsdf type=\"phong\"/>"));
    const Bsdf& b = sphere_bsdf(d);
    EXPECT_EQ(b.type, BsdfType::Phong);
    EXPECT_FLOAT_EQ(b.diffuse.g, 0.5f);
    EXPECT_FLOAT_EQ(b.specular.g, 0.2f);
    EXPECT_FLOAT_EQ(b.alpha_u, 30.0f);
    const Scene s = load(scene("<bsdf type=\"phong\"><rgb name=\"diffuseReflectance\" value=\"0.25 0.3 0.1\"/>"
                               "<rgb name=\"specularReflectance\" value=\"0.025 0.03 0.01\"/><float name=\"exponent\" value=\"20.5\"/></bsdf>"));
    EXPECT_FLOAT_EQ(sphere_bsdf(s).diffuse.g, 0.3f);
    EXPECT_FLOAT_EQ(sphere_bsdf(s).specular.r, 0.025f);
    EXPECT_FLOAT_EQ(sphere_bsdf(s).alpha_u, 20.5f);
}

// living_room's "windows": 0.992 + 0.098 > 1, so Mitsuba scales both by 0.99 / 1.0902, with a warning;
// ensureEnergyConservation=false keeps them.
TEST(LoaderPhong, EnergyConservationScalesAsMitsuba) {
    const std::string body = "<rgb name=\"diffuseReflectance\" value=\"0.992157\"/><rgb name=\"specularReflectance\" value=\"0.0980392\"/>";
    std::vector<std::string> w;
    const Scene s = load(scene("<bsdf type=\"phong\">" + body + "</bsdf>"), &w);
    const float k = 0.99f / (0.992157f + 0.0980392f);
    EXPECT_NEAR(sphere_bsdf(s).diffuse.r, 0.992157f * k, 1e-6f);
    EXPECT_NEAR(sphere_bsdf(s).specular.b, 0.0980392f * k, 1e-6f);
    ASSERT_EQ(w.size(), 1u);
    EXPECT_NE(w[0].find("scaled by"), std::string::npos) << w[0];
    w.clear();
    const Scene keep = load(scene("<bsdf type=\"phong\"><boolean name=\"ensureEnergyConservation\" value=\"false\"/>" + body + "</bsdf>"), &w);
    EXPECT_FLOAT_EQ(sphere_bsdf(keep).diffuse.r, 0.992157f);
    EXPECT_TRUE(w.empty());
}

// living_room's ceiling_list: weights "1, 1" with ensureEnergyConservation=false stay 1, 1; by default
// Mitsuba divides them by their sum (with a warning).
TEST(LoaderMixture, WeightsPartsAndLinks) {
    const std::string parts = "<string name=\"weights\" value=\"1, 1\"/>\n"
                              "<bsdf type=\"conductor\" id=\"mirror\"><string name=\"material\" value=\"Ag\"/></bsdf>\n"
                              "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.9\"/></bsdf></bsdf>";
    std::vector<std::string> w;
    const Scene s = load(scene("<bsdf type=\"mixturebsdf\"><boolean name=\"ensureEnergyConservation\" value=\"false\"/>" + parts), &w);
    const Bsdf& m = sphere_bsdf(s);
    ASSERT_EQ(m.type, BsdfType::Mixture);
    ASSERT_EQ(m.part_count, 2);
    EXPECT_EQ(m.part_weight[0], 1.0f);
    EXPECT_EQ(m.part_weight[1], 1.0f);
    EXPECT_EQ(m.part[0], &s.bsdfs[m.part_index[0]]);
    EXPECT_EQ(m.part[0]->type, BsdfType::Conductor);
    EXPECT_EQ(m.part[1]->type, BsdfType::Diffuse);
    EXPECT_FLOAT_EQ(m.part[1]->diffuse.g, 0.9f);
    EXPECT_TRUE(bsdf_has_delta_lobe(m) && !bsdf_is_delta(m) && has_specular_surfaces(s));
    EXPECT_TRUE(w.empty());
    const Scene n = load(scene("<bsdf type=\"mixturebsdf\">" + parts), &w);
    EXPECT_EQ(sphere_bsdf(n).part_weight[0], 0.5f);
    ASSERT_EQ(w.size(), 1u);
    EXPECT_NE(w[0].find("divided"), std::string::npos);
    // Separators: spaces, commas, semicolons; a <ref> part; a nested mixture.
    const Scene r = load(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"0.2;0.3 0.5\"/>"
                               "<ref id=\"d\"/><bsdf type=\"phong\"/><bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"1\"/>"
                               "<bsdf type=\"roughconductor\"/></bsdf></bsdf>",
                               "<bsdf type=\"diffuse\" id=\"d\"/>\n"));
    const Bsdf& m3 = sphere_bsdf(r);
    ASSERT_EQ(m3.part_count, 3);
    EXPECT_FLOAT_EQ(m3.part_weight[2], 0.5f);
    EXPECT_EQ(m3.part[2]->type, BsdfType::Mixture);
    EXPECT_EQ(m3.part[2]->part[0]->type, BsdfType::RoughConductor);
}

TEST(LoaderBlend, WeightConstantTextureAndClamp) {
    const std::string parts = "<bsdf type=\"diffuse\"/><bsdf type=\"roughdielectric\"/></bsdf>";
    const Scene s = load(scene("<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.3\"/>" + parts));
    const Bsdf& b = sphere_bsdf(s);
    EXPECT_FLOAT_EQ(b.part_weight[0], 0.7f);
    EXPECT_FLOAT_EQ(b.part_weight[1], 0.3f);
    EXPECT_TRUE(bsdf_transmits(b));
    EXPECT_FLOAT_EQ(sphere_bsdf(load(scene("<bsdf type=\"blendbsdf\">" + parts))).part_weight[1], 0.5f);  // default
    std::vector<std::string> w;
    EXPECT_FLOAT_EQ(sphere_bsdf(load(scene("<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"1.5\"/>" + parts), &w)).part_weight[1], 1.0f);
    EXPECT_EQ(w.size(), 1u);
    // A checkerboard weight (0.4 / 0.2 by default) and a checkerboard diffuse part: both resolved per hit.
    const Scene t = load(scene("<bsdf type=\"blendbsdf\"><texture type=\"checkerboard\" name=\"weight\"/>"
                               "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf>"
                               "<bsdf type=\"phong\"/></bsdf>"));
    const Bsdf& tb = sphere_bsdf(t);
    ASSERT_TRUE(tb.textured_params && tb.textured);
    SurfaceHit hit;
    hit.bsdf = t.spheres[0].bsdf;
    hit.uv = {0.1f, 0.1f};
    BsdfScratch scratch;
    const Bsdf& r = scene_bsdf_at(t, hit, &scratch);
    EXPECT_FLOAT_EQ(r.part_weight[1], 0.4f);
    EXPECT_FLOAT_EQ(r.part[0]->diffuse.g, 0.4f);
    EXPECT_EQ(r.part[0], &scratch.parts[0]);
    EXPECT_EQ(r.part[1], tb.part[1]);  // untextured: the scene's own
    hit.uv = {0.6f, 0.1f};
    EXPECT_FLOAT_EQ(scene_bsdf_at(t, hit, &scratch).part[0]->diffuse.g, 0.2f);
}

// Around a mixture, bumpmap and twosided wrap the whole (Scene::intersect bumps the hit's frame, which
// every part then sees; the back side mirrors the front for every part).
TEST(LoaderMixture, WrappedInBumpmapAndTwosided) {
    const Scene s = load(scene("<bsdf type=\"twosided\"><bsdf type=\"bumpmap\"><texture type=\"checkerboard\"/>"
                               "<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"phong\"/></bsdf></bsdf></bsdf>"));
    const Bsdf& b = sphere_bsdf(s);
    EXPECT_EQ(b.type, BsdfType::Mixture);
    EXPECT_TRUE(b.two_sided);
    EXPECT_GE(b.tex_bump, 0);
    EXPECT_EQ(b.part[1]->type, BsdfType::Phong);
}

TEST(LoaderMixture, RefusedAsMitsubaRefuses) {
    const std::string d = "<bsdf type=\"diffuse\"/>";
    expect_error(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"1, 2\"/>" + d + d + d + "</bsdf>"), 4,
                 "2 weights for 3 nested BSDFs");
    expect_error(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"1, -2\"/>" + d + d + "</bsdf>"), 4, "is negative");
    expect_error(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"1, x\"/>" + d + d + "</bsdf>"), 4, "not a number");
    expect_error(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"0 0\"/>" + d + d + "</bsdf>"), 4, "sum to more than 0");
    expect_error(scene("<bsdf type=\"mixturebsdf\">" + d + "</bsdf>"), 4, "needs weights");
    expect_error(scene("<bsdf type=\"blendbsdf\">" + d + "</bsdf>"), 4, "exactly two nested BSDFs");
    expect_error(scene("<bsdf type=\"blendbsdf\">" + d + d + d + "</bsdf>"), 4, "exactly two nested BSDFs");
    expect_error(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"1 1 1 1 1\"/>" + d + d + d + d + d + "</bsdf>"), 4,
                 "at most 4");
    expect_error(scene("<bsdf type=\"twosided\"><bsdf type=\"blendbsdf\">" + d + "<bsdf type=\"dielectric\"/></bsdf></bsdf>"), 4,
                 "twosided cannot wrap a BSDF that transmits");
    expect_error(scene("<bsdf type=\"phong\"><float name=\"exponent\" value=\"-1\"/></bsdf>"), 4, "exponent must be");
    expect_error(scene("<bsdf type=\"blendbsdf\"><bsdf type=\"bumpmap\"><texture type=\"checkerboard\"/>" + d + "</bsdf>" + d + "</bsdf>"),
                 4, "a bumpmap inside");
    expect_error(scene("<bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"1 1\"/><bsdf type=\"mask\">"
                       "<spectrum name=\"opacity\" value=\"0.5\"/>" + d + "</bsdf>" + d + "</bsdf>"),
                 4, "a mask inside");
}

}  // namespace
}  // namespace iris
