// Textured BSDF parameters end to end: the scene reader turns nested <texture>s, top-level textures
// referenced by <ref name=... id=...>, textures inside twosided and `scale` wrappers into Scene::textures
// and Bsdf::tex_* (one Texture per distinct texture, one decode per file); Scene::intersect gives the
// hit's uv; scene_bsdf_at evaluates the textures there (and leaves untextured BSDFs alone, by
// reference); a render of a textured rectangle under a constant environment shows each pixel's texel.
// Bump maps (bumpmap): the tilted shading normal against the closed form, the texture's gradient, and
// the wrapper's file forms and errors.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "formats/png.h"
#include "formats/scene_xml.h"
#include "libcommon/scene.h"
#include "libcommon/spectrum.h"
#include "libcommon/texture.h"
#include "tools/render/integrator.h"
#include "support/temp_dir.h"

namespace fs = std::filesystem;

namespace iris {
namespace {

using iris::test::TempDir;

// A 2 x 2 PNG, 8-bit values k / 255 as given (sRGB-encoded by convention): rows top to bottom.
const float kTexels[12] = {200 / 255.0f, 40 / 255.0f, 40 / 255.0f,   40 / 255.0f, 200 / 255.0f, 40 / 255.0f,
                           40 / 255.0f, 40 / 255.0f, 200 / 255.0f,   230 / 255.0f, 230 / 255.0f, 60 / 255.0f};

RGB texel_linear(int x, int y) {
    const float* t = &kTexels[3 * (2 * y + x)];
    return RGB(srgb_to_linear(t[0]), srgb_to_linear(t[1]), srgb_to_linear(t[2]));
}

void write_texture(const TempDir& d, const std::string& name) {
    write_png(d.file(name), 2, 2, std::vector<float>(std::begin(kTexels), std::end(kTexels)));
}

std::string scene_text(const std::string& body, int width = 16, int height = 16) {
    return "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
           "  <sensor type=\"perspective\">\n    <float name=\"fov\" value=\"30\"/>\n"
           "    <transform name=\"toWorld\"><lookAt origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n"
           "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"" + std::to_string(width) +
           "\"/><integer name=\"height\" value=\"" + std::to_string(height) + "\"/></film>\n  </sensor>\n" +
           body + "</scene>\n";
}

Scene load_quiet(const std::string& path) {
    std::vector<std::string> warnings;
    SceneLoadOptions o;
    o.warnings = &warnings;
    return load_scene(path, o);
}

void expect_rgb(RGB c, RGB want, float tol, const std::string& what = "") {
    EXPECT_NEAR(c.r, want.r, tol) << what;
    EXPECT_NEAR(c.g, want.g, tol) << what;
    EXPECT_NEAR(c.b, want.b, tol) << what;
}

TEST(TexturedBsdf, NestedAndReferencedTexturesParseAndShare) {
    TempDir d;
    write_texture(d, "wood.png");
    const std::string path = d.write("s.xml", scene_text(
        "  <texture type=\"bitmap\" id=\"wood\">\n    <string name=\"filename\" value=\"wood.png\"/>\n"
        "    <string name=\"filterType\" value=\"nearest\"/>\n  </texture>\n"
        "  <bsdf type=\"twosided\" id=\"floor\">\n    <bsdf type=\"diffuse\">\n"
        "      <ref name=\"reflectance\" id=\"wood\"/>\n    </bsdf>\n  </bsdf>\n"
        // A rectangle with the nested texture: the same file and options as "wood", so the same Texture.
        "  <shape type=\"rectangle\" id=\"a\">\n    <bsdf type=\"diffuse\">\n"
        "      <texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"wood.png\"/>"
        "<string name=\"filterType\" value=\"nearest\"/></texture>\n    </bsdf>\n  </shape>\n"
        "  <shape type=\"rectangle\" id=\"b\"><ref id=\"floor\"/></shape>\n"
        // The same file scaled in uv: a second Texture with the same texels, the file decoded once.
        "  <shape type=\"rectangle\" id=\"c\">\n    <bsdf type=\"plastic\">\n"
        "      <texture type=\"bitmap\" name=\"diffuseReflectance\"><string name=\"filename\" value=\"wood.png\"/>"
        "<float name=\"uscale\" value=\"4\"/></texture>\n"
        "      <texture type=\"checkerboard\" name=\"specularReflectance\"><rgb name=\"color0\" value=\"0.9\"/>"
        "<float name=\"uvscale\" value=\"3\"/></texture>\n    </bsdf>\n  </shape>\n"
        "  <shape type=\"rectangle\" id=\"d\">\n    <bsdf type=\"roughconductor\">\n"
        "      <texture type=\"scale\" name=\"specularReflectance\"><float name=\"scale\" value=\"0.5\"/>"
        "<ref id=\"wood\"/></texture>\n"
        "      <texture type=\"checkerboard\" name=\"alpha\"><rgb name=\"color0\" value=\"0.3\"/>"
        "<rgb name=\"color1\" value=\"0.1, 0.2, 0.3\"/></texture>\n    </bsdf>\n  </shape>\n"
        "  <emitter type=\"constant\"/>\n"));
    Scene s = load_quiet(path);
    ASSERT_EQ(s.meshes.size(), 4u);
    const Bsdf& a = s.bsdfs[s.meshes[0].bsdf];
    const Bsdf& b = s.bsdfs[s.meshes[1].bsdf];
    const Bsdf& c = s.bsdfs[s.meshes[2].bsdf];
    const Bsdf& m = s.bsdfs[s.meshes[3].bsdf];
    EXPECT_TRUE(a.textured && b.textured && c.textured && m.textured);
    EXPECT_TRUE(b.two_sided);
    ASSERT_GE(a.tex_diffuse, 0);
    EXPECT_EQ(a.tex_diffuse, b.tex_diffuse) << "the nested texture equals the referenced one: shared";
    EXPECT_EQ(a.tex_specular, -1);
    // wood, wood scaled in u, the checkerboard, the scaled copy, the alpha checkerboard.
    EXPECT_EQ(s.textures.size(), 5u);
    const Texture& wood = s.textures[size_t(a.tex_diffuse)];
    ASSERT_EQ(wood.width, 2);
    ASSERT_EQ(wood.height, 2);
    EXPECT_EQ(wood.filter, TextureFilter::Nearest);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 2; ++x) expect_rgb(wood.texels[size_t(2 * y + x)], texel_linear(x, y), 1e-6f, "texel");
    ASSERT_GE(c.tex_diffuse, 0);
    EXPECT_NE(c.tex_diffuse, a.tex_diffuse);
    EXPECT_EQ(s.textures[size_t(c.tex_diffuse)].uscale, 4.0f);
    EXPECT_EQ(s.textures[size_t(c.tex_diffuse)].texels.size(), 4u);
    const Texture& checker = s.textures[size_t(c.tex_specular)];
    EXPECT_EQ(checker.type, TextureType::Checkerboard);
    EXPECT_EQ(checker.uscale, 3.0f);
    EXPECT_EQ(checker.vscale, 3.0f);
    expect_rgb(checker.color0, RGB(0.9f), 0);
    expect_rgb(checker.color1, RGB(0.2f), 0);  // Mitsuba's default
    const Texture& half = s.textures[size_t(m.tex_specular)];
    expect_rgb(half.texels[3], texel_linear(1, 1) * 0.5f, 1e-6f, "scale texture");
    EXPECT_EQ(m.tex_alpha_u, m.tex_alpha_v) << "an isotropic textured alpha drives both";

    // At the hit: the rough conductor's alpha is the texture's mean, its reflectance the scaled texel.
    SurfaceHit hit;
    hit.bsdf = s.meshes[3].bsdf;
    hit.uv = Vec2{0.1f, 0.1f};  // checkerboard cell (0, 0): color0; bitmap texel (0, 0)
    BsdfScratch scratch;
    const Bsdf& r = scene_bsdf_at(s, hit, &scratch);
    EXPECT_EQ(&r, &scratch.bsdf);
    EXPECT_FLOAT_EQ(r.alpha_u, 0.3f);
    hit.uv = Vec2{0.6f, 0.1f};  // cell (1, 0): color1, mean 0.2
    EXPECT_NEAR(scene_bsdf_at(s, hit, &scratch).alpha_v, 0.2f, 1e-6f);

    // The plastic's sampling weight follows the reflectances at the hit.
    hit.bsdf = s.meshes[2].bsdf;
    hit.uv = Vec2{0.01f, 0.01f};
    const Bsdf& p = scene_bsdf_at(s, hit, &scratch);
    const float ls = luminance(RGB(0.9f)), ld = luminance(p.diffuse);
    EXPECT_NEAR(p.specular_sampling_weight, ls / (ls + ld), 1e-6f);
    EXPECT_NEAR(p.fdr_int, c.fdr_int, 0) << "the IOR-only constant is copied, not recomputed";
}

TEST(TexturedBsdf, UntexturedBsdfIsReturnedByReference) {
    TempDir d;
    Scene s = load_quiet(d.write("s.xml", scene_text("  <shape type=\"rectangle\"/>\n  <emitter type=\"constant\"/>\n")));
    SurfaceHit hit;
    hit.bsdf = s.meshes[0].bsdf;
    BsdfScratch scratch;
    EXPECT_FALSE(s.bsdfs[hit.bsdf].textured);
    EXPECT_EQ(&scene_bsdf_at(s, hit, &scratch), &s.bsdfs[hit.bsdf]);
}

TEST(TexturedBsdf, HitUvOnTheRectangleIsMitsubas) {
    TempDir d;
    write_texture(d, "t.png");
    // Mitsuba's rectangle: [-1, 1]^2 at z = 0, uv = ((x + 1) / 2, (y + 1) / 2); scaled by 2 in x here.
    Scene s = load_quiet(d.write("s.xml", scene_text(
        "  <shape type=\"rectangle\">\n    <transform name=\"toWorld\"><scale x=\"2\"/></transform>\n"
        "    <bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
        "<string name=\"filename\" value=\"t.png\"/></texture></bsdf>\n  </shape>\n  <emitter type=\"constant\"/>\n")));
    for (Vec2 xy : {Vec2{0.5f, -0.5f}, Vec2{-1.9f, 0.8f}, Vec2{1.2f, 0.3f}}) {
        Ray ray;
        ray.o = Vec3(xy.x, xy.y, 3);
        ray.d = Vec3(0, 0, -1);
        SurfaceHit hit;
        ASSERT_TRUE(s.intersect(ray, &hit));
        EXPECT_NEAR(hit.uv.x, (xy.x / 2 + 1) / 2, 1e-6f);
        EXPECT_NEAR(hit.uv.y, (xy.y + 1) / 2, 1e-6f);
    }
}

// A camera looking at a textured rectangle under a constant environment of radiance 1: a diffuse
// surface seen from anywhere reflects its reflectance times 1, so each pixel's mean is the texel its
// centre sees (taken from the uv at the pixel's centre). Pixels near a texel edge are skipped (the
// pixel filter blends neighbours there); the others must agree within 5 standard errors of the render
// (variance layer) plus 1e-3 for the film filter's tails.
TEST(TexturedBsdf, DiffuseBitmapRendersTheTexelColour) {
    TempDir d;
    write_texture(d, "t.png");
    const int W = 24, H = 24;
    Scene s = load_quiet(d.write("s.xml", scene_text(
        "  <shape type=\"rectangle\">\n    <transform name=\"toWorld\"><scale value=\"2\"/></transform>\n"
        "    <bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
        "<string name=\"filename\" value=\"t.png\"/><string name=\"filterType\" value=\"nearest\"/></texture></bsdf>\n"
        "  </shape>\n  <emitter type=\"constant\"/>\n", W, H)));
    RenderOptions o;
    o.spp = 64;
    o.threads = 1;
    o.seed = 3;
    o.quiet = true;
    o.variance_layer = true;
    RenderStats stats;
    const Image img = render_image(s, o, &stats);
    Camera cam = s.camera;
    camera_prepare(cam, W, H);
    const char* names[3] = {"R", "G", "B"};
    int checked = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            // The texel under the pixel centre and under points 2 pixels away: all equal = an interior pixel.
            int texel = -2;
            bool interior = true;
            for (Vec2 off : {Vec2{0, 0}, Vec2{-2, -2}, Vec2{2, -2}, Vec2{-2, 2}, Vec2{2, 2}}) {
                SurfaceHit hit;
                if (!s.intersect(camera_ray(cam, float(x) + 0.5f + off.x, float(y) + 0.5f + off.y, W, H), &hit)) {
                    interior = false;
                    break;
                }
                const int t = int(std::floor(hit.uv.x * 2)) + 2 * int(std::floor(hit.uv.y * 2));
                if (texel != -2 && t != texel) interior = false;
                texel = t;
            }
            if (!interior) continue;
            const RGB want = texel_linear(texel % 2, texel / 2);
            const size_t i = size_t(y) * W + size_t(x);
            for (int c = 0; c < 3; ++c) {
                const float mean = img.data[size_t(img.channel_index(names[c]))][i];
                const float var = img.data[size_t(img.channel_index(std::string("variance.") + names[c]))][i];
                EXPECT_NEAR(mean, want[c], 5.0f * std::sqrt(var) + 1e-3f) << "pixel " << x << "," << y << " channel " << c;
            }
            ++checked;
        }
    EXPECT_GT(checked, W * H / 4) << "the rectangle must cover interior pixels of all four texels";
}

// OBJ texture coordinates as Mitsuba reads them: flipTexCoords (default true) gives v' = 1 - v; one
// vertex per distinct (position, normal, uv), so a seam splits a vertex.
TEST(TexturedBsdf, ObjTexcoordsLoadWithMitsubasFlip) {
    TempDir d;
    write_texture(d, "t.png");
    d.write("q.obj", "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                     "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.25 0.75\n"
                     "f 1/1 2/2 3/3 4/4\nf 1/5 3/3 4/4\n");
    auto scene = [&](bool flip_given, bool flip) {
        std::string extra = flip_given ? std::string("<boolean name=\"flipTexCoords\" value=\"") + (flip ? "true" : "false") + "\"/>" : "";
        return load_quiet(d.write("s.xml", scene_text(
            "  <shape type=\"obj\"><string name=\"filename\" value=\"q.obj\"/>" + extra +
            "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"t.png\"/>"
            "</texture></bsdf></shape>\n  <emitter type=\"constant\"/>\n")));
    };
    for (int mode = 0; mode < 3; ++mode) {
        const bool flip = mode != 2;
        Scene s = scene(mode > 0, flip);
        const Mesh& m = s.meshes[0];
        ASSERT_EQ(m.uvs.size(), m.positions.size());
        EXPECT_EQ(m.positions.size(), 5u) << "vertex 1 appears with two uvs";
        // Vertex for position (1, 1): OBJ uv (1, 1).
        for (size_t i = 0; i < m.positions.size(); ++i) {
            const Vec3 p = m.positions[i];
            const Vec2 t = m.uvs[i];
            if (p.x == 1 && p.y == 1) { EXPECT_EQ(t.y, flip ? 0.0f : 1.0f) << mode; }
            if (p.x == 1 && p.y == -1) { EXPECT_EQ(t.y, flip ? 1.0f : 0.0f) << mode; }
            if (t.x == 0.25f) { EXPECT_EQ(t.y, flip ? 0.25f : 0.75f) << mode; }
        }
        // At a hit: (0.5, 0.5) on the quad's first triangle fan -> OBJ uv (0.75, 0.75).
        Ray ray;
        ray.o = Vec3(0.5f, -0.2f, 3);
        ray.d = Vec3(0, 0, -1);
        SurfaceHit hit;
        ASSERT_TRUE(s.intersect(ray, &hit));
        EXPECT_NEAR(hit.uv.x, 0.75f, 1e-6f);
        EXPECT_NEAR(hit.uv.y, flip ? 1.0f - 0.4f : 0.4f, 1e-6f);
    }
    // Without vt records: Mitsuba's uv = the barycentrics of the triangle's vertices 1 and 2.
    d.write("plain.obj", "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n");
    {
        Scene s = load_quiet(d.write("p.xml", scene_text(
            "  <shape type=\"obj\"><string name=\"filename\" value=\"plain.obj\"/>"
            "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"t.png\"/>"
            "</texture></bsdf></shape>\n  <emitter type=\"constant\"/>\n")));
        EXPECT_TRUE(s.meshes[0].uvs.empty());
        Ray ray;
        ray.o = Vec3(0.5f, -0.25f, 3);
        ray.d = Vec3(0, 0, -1);
        SurfaceHit hit;
        ASSERT_TRUE(s.intersect(ray, &hit));
        // p = p0 + b1 (p1 - p0) + b2 (p2 - p0) = (-1 + 2 b1 + 2 b2, -1 + 2 b2): b2 = 0.375, b1 = 0.375.
        EXPECT_NEAR(hit.uv.x, 0.375f, 1e-6f);
        EXPECT_NEAR(hit.uv.y, 0.375f, 1e-6f);
    }
    // A texture coordinate index past the end is the file's error, naming it.
    d.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n");
    try {
        load_quiet(d.write("b.xml", scene_text("  <shape type=\"obj\"><string name=\"filename\" value=\"bad.obj\"/></shape>\n")));
        ADD_FAILURE() << "no error";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("texture coordinate 2"), std::string::npos) << e.what();
    }
}

// Mitsuba's cube maps every face onto [0, 1]^2 (corner order of its table); its disk has
// uv = (radius, angle / 2 pi); its sphere (phi / 2 pi, theta / pi) in the object frame of toWorld.
TEST(TexturedBsdf, CubeDiskAndSphereUvsAreMitsubas) {
    TempDir d;
    write_texture(d, "t.png");
    const std::string bsdf = "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
                             "<string name=\"filename\" value=\"t.png\"/></texture></bsdf>";
    Scene s = load_quiet(d.write("s.xml", scene_text(
        "  <shape type=\"cube\">" + bsdf + "</shape>\n"
        "  <shape type=\"disk\"><transform name=\"toWorld\"><translate x=\"10\"/></transform>" + bsdf + "</shape>\n"
        "  <shape type=\"sphere\"><transform name=\"toWorld\"><rotate x=\"1\" angle=\"90\"/><translate x=\"-10\"/></transform>" +
        bsdf + "</shape>\n  <emitter type=\"constant\"/>\n")));
    auto uv_at = [&](Vec3 o, Vec3 dir) {
        Ray ray;
        ray.o = o;
        ray.d = dir;
        SurfaceHit hit;
        EXPECT_TRUE(s.intersect(ray, &hit));
        return hit.uv;
    };
    // Cube, +z face: corners (1,-1) (1,1) (-1,1) (-1,-1) at uv (0,1) (1,1) (1,0) (0,0): uv = ((y+1)/2, (x+1)/2).
    Vec2 t = uv_at(Vec3(0.5f, -0.2f, 5), Vec3(0, 0, -1));
    EXPECT_NEAR(t.x, 0.4f, 1e-6f);
    EXPECT_NEAR(t.y, 0.75f, 1e-6f);
    // -y face: corners (1,-1) (1,1) (-1,1) (-1,-1) in (x, z) at the same uvs: uv = ((z+1)/2, (x+1)/2).
    t = uv_at(Vec3(-0.6f, -5, 0.2f), Vec3(0, 1, 0));
    EXPECT_NEAR(t.x, 0.6f, 1e-6f);
    EXPECT_NEAR(t.y, 0.2f, 1e-6f);
    // Disk: radius 0.5 at 60 degrees (fan interpolation: the radius within 1e-4, the angle within half a segment).
    t = uv_at(Vec3(10 + 0.25f, 0.5f * std::sqrt(0.75f), 5), Vec3(0, 0, -1));
    EXPECT_NEAR(t.x, 0.5f, 1e-4f);
    EXPECT_NEAR(t.y, 1.0f / 6.0f, 1.0f / 1024);
    // Just below angle 0 (the seam): v near 1, not interpolated back towards 0.
    t = uv_at(Vec3(10 + 0.8f, -1e-3f, 5), Vec3(0, 0, -1));
    EXPECT_GT(t.y, 0.999f);
    // Sphere rotated 90 degrees about x: its pole (+z) lies at world -y, its +y axis at world +z.
    t = uv_at(Vec3(-10, -5, 0), Vec3(0, 1, 0));
    EXPECT_NEAR(t.y, 0.0f, 1e-3f);
    t = uv_at(Vec3(-5, 0, 0), Vec3(-1, 0, 0));  // object +x: phi = 0, theta = 90 degrees
    EXPECT_NEAR(t.x, 0.0f, 1e-4f);
    EXPECT_NEAR(t.y, 0.5f, 1e-4f);
    t = uv_at(Vec3(-10, 0, 5), Vec3(0, 0, -1));  // object +y: phi = 90 degrees
    EXPECT_NEAR(t.x, 0.25f, 1e-4f);
    EXPECT_NEAR(t.y, 0.5f, 1e-4f);
}

// Stage files are matched to a scene by its fingerprint: a texture file's bytes are part of it.
TEST(TexturedBsdf, FingerprintCoversTextureFiles) {
    TempDir d;
    write_texture(d, "t.png");
    const std::string xml = d.write("s.xml", scene_text(
        "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
        "<string name=\"filename\" value=\"t.png\"/></texture></bsdf></shape>\n  <emitter type=\"constant\"/>\n"));
    const std::string a = load_quiet(xml).fingerprint;
    EXPECT_EQ(load_quiet(xml).fingerprint, a);
    std::vector<float> other(std::begin(kTexels), std::end(kTexels));
    other[4] = 41 / 255.0f;  // one texel's green one step brighter
    write_png(d.file("t.png"), 2, 2, other);
    EXPECT_NE(load_quiet(xml).fingerprint, a);
}

TEST(TexturedBsdf, TextureErrorsNameTheParameter) {
    TempDir d;
    write_texture(d, "t.png");
    auto error_of = [&](const std::string& bsdf_body) -> std::string {
        try {
            load_quiet(d.write("e.xml", scene_text("  <shape type=\"rectangle\">\n" + bsdf_body + "\n  </shape>\n")));
        } catch (const SceneError& e) {
            return e.what();
        }
        return "(no error)";
    };
    const std::string tex = "<texture type=\"bitmap\" name=\"NAME\"><string name=\"filename\" value=\"t.png\"/></texture>";
    auto with = [&](const std::string& name) {
        std::string t = tex;
        return t.replace(t.find("NAME"), 4, name);
    };
    EXPECT_NE(error_of("<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/>" + with("reflectance") + "</bsdf>")
                  .find("given twice"), std::string::npos);
    EXPECT_NE(error_of("<bsdf type=\"conductor\">" + with("eta") + "</bsdf>").find("\"eta\" of bsdf \"conductor\" cannot be a texture"),
              std::string::npos);
    EXPECT_NE(error_of("<bsdf type=\"diffuse\">" + with("reflectanse") + "</bsdf>").find("\"reflectanse\""), std::string::npos);
    EXPECT_NE(error_of("<bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"nope\"/></bsdf>").find("undefined reference \"nope\""),
              std::string::npos);
    EXPECT_NE(error_of("<bsdf type=\"roughconductor\">" + with("alpha") + "<float name=\"alphaU\" value=\"0.1\"/>"
                       "<float name=\"alphaV\" value=\"0.1\"/></bsdf>").find("either alpha or alphaU/alphaV"),
              std::string::npos);
}

}  // namespace
}  // namespace iris

namespace iris {
namespace {

// ---- bumpmap ---------------------------------------------------------------------------------------------

// A 2 x 2 grey height map whose bilinear interpolant is a plane, h = a X + b Y in texel units between the
// texel centres (values k / 255, read linearly with gamma 1): dh/du = 2 a, dh/dv = 2 b per unit of uv
// (the test's scale texture multiplies both).
constexpr float kBumpA = 102 / 255.0f, kBumpB = 51 / 255.0f;
void write_ramp(const TempDir& d, const std::string& name, float a = kBumpA, float b = kBumpB) {
    const float h[4] = {0, a, b, a + b};  // rows top (v = 0) to bottom
    std::vector<float> rgb;
    for (float v : h) rgb.insert(rgb.end(), {v, v, v});
    write_png(d.file(name), 2, 2, rgb);
}
std::string bumped(const std::string& inner_bsdf, float scale = 0.05f) {
    return "<bsdf type=\"bumpmap\"><texture type=\"scale\"><float name=\"scale\" value=\"" + std::to_string(scale) +
           "\"/><texture type=\"bitmap\"><string name=\"filename\" value=\"ramp.png\"/><float name=\"gamma\" value=\"1\"/>"
           "</texture></texture>" + inner_bsdf + "</bsdf>";
}

// Mitsuba's bump: tangents dpdu + n dh/du, dpdv + n dh/dv, the new normal their cross product. On the
// rectangle scaled by 2 in x (dpdu = (4, 0, 0), dpdv = (0, 2, 0)) with dh/du = 2 a s, dh/dv = 2 b s (s the
// scale texture's factor): n' = normalize(-2 dh/du, -4 dh/dv, 8) -- tilted down the slope, along both axes.
TEST(BumpMap, TiltsTheShadingNormalDownTheHeightGradient) {
    TempDir d;
    write_ramp(d, "ramp.png");
    Scene s = load_quiet(d.write("s.xml", scene_text(
        "  <shape type=\"rectangle\">\n    <transform name=\"toWorld\"><scale x=\"2\"/></transform>\n    " +
        bumped("<bsdf type=\"diffuse\"/>") + "\n  </shape>\n  <emitter type=\"constant\"/>\n")));
    const double hu = 2 * kBumpA * 0.05, hv = 2 * kBumpB * 0.05;
    const double len = std::sqrt(4 * hu * hu + 16 * hv * hv + 64);
    for (Vec2 xy : {Vec2{0.0f, 0.0f}, Vec2{0.5f, -0.3f}, Vec2{-0.7f, 0.4f}}) {  // (between the texel centres)
        Ray ray;
        ray.o = Vec3(xy.x, xy.y, 3);
        ray.d = Vec3(0, 0, -1);
        SurfaceHit hit;
        ASSERT_TRUE(s.intersect(ray, &hit));
        EXPECT_NEAR(hit.ns.x, -2 * hu / len, 1e-5);
        EXPECT_NEAR(hit.ns.y, -4 * hv / len, 1e-5);
        EXPECT_NEAR(hit.ns.z, 8 / len, 1e-5);
        EXPECT_NEAR(hit.frame.n.x, hit.ns.x, 0);
        EXPECT_EQ(hit.ng.z, 1.0f) << "the geometric normal stays";
    }
    // Without the wrapper, the same surface keeps its normal.
    Scene flat = load_quiet(d.write("f.xml", scene_text(
        "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"/></shape>\n  <emitter type=\"constant\"/>\n")));
    SurfaceHit hit;
    ASSERT_TRUE(flat.intersect(Ray{Vec3(0, 0, 3), Vec3(0, 0, -1)}, &hit));
    EXPECT_EQ(hit.ns.z, 1.0f);
}

// On a sphere (Mitsuba's uv: u = phi / 2 pi, v = theta / pi; dp/du = 2 pi r (-y, x, 0), dp/dv orthogonal to
// it) a height that grows with u alone tilts the normal against the direction of growing phi by
// atan(dh/du / |dp/du|), |dp/du| = 2 pi r sin(theta).
TEST(BumpMap, OnASphereTiltsAlongTheParametrisation) {
    TempDir d;
    write_ramp(d, "ramp.png", kBumpA, 0.0f);  // dh/dv = 0
    const float r = 1.5f;
    Scene s = load_quiet(d.write("s.xml", scene_text("  <shape type=\"sphere\"><float name=\"radius\" value=\"" +
                                                     std::to_string(r) + "\"/>" + bumped("<bsdf type=\"diffuse\"/>") +
                                                     "</shape>\n  <emitter type=\"constant\"/>\n")));
    const double hu = 2 * kBumpA * 0.05;
    for (float phi_deg : {100.0f, 135.0f, 160.0f}) {  // u between the texel centres (0.25 .. 0.75)
        const float phi = phi_deg * kPi / 180, theta = 70 * kPi / 180;
        const Vec3 n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
        Ray ray;
        ray.o = n * 5.0f;
        ray.d = -n;
        SurfaceHit hit;
        ASSERT_TRUE(s.intersect(ray, &hit));
        const Vec3 u_dir(-std::sin(phi), std::cos(phi), 0);  // direction of growing phi
        const double tilt = std::atan(hu / (2 * kPi * r * std::sin(theta)));
        EXPECT_NEAR(dot(hit.ns, n), std::cos(tilt), 1e-5) << phi_deg;
        EXPECT_NEAR(dot(hit.ns, u_dir), -std::sin(tilt), 1e-5) << phi_deg;
        EXPECT_NEAR(length(hit.ns), 1.0f, 1e-6f);
    }
}

// The wrapper in the scene file: either order of texture and BSDF, a referenced texture or BSDF, inside and
// around twosided; the errors Mitsuba gives (a bitmap without an explicit gamma) and the ones of a wrapper
// that lacks its texture or BSDF, or wraps another bump map.
TEST(BumpMap, SceneFileFormsAndErrors) {
    TempDir d;
    write_ramp(d, "ramp.png");
    const std::string tex = "<texture type=\"bitmap\"><string name=\"filename\" value=\"ramp.png\"/><float name=\"gamma\" value=\"1\"/></texture>";
    auto shape = [](const std::string& bsdf) { return "  <shape type=\"rectangle\">" + bsdf + "</shape>\n"; };
    const std::string forms =
        "  <texture type=\"bitmap\" id=\"h\"><string name=\"filename\" value=\"ramp.png\"/><float name=\"gamma\" value=\"1\"/></texture>\n"
        "  <bsdf type=\"roughplastic\" id=\"rp\"/>\n" +
        shape("<bsdf type=\"bumpmap\"><bsdf type=\"diffuse\"/>" + tex + "</bsdf>") +
        shape("<bsdf type=\"bumpmap\"><ref id=\"h\"/><ref id=\"rp\"/></bsdf>") +
        shape("<bsdf type=\"twosided\"><bsdf type=\"bumpmap\">" + tex + "<bsdf type=\"diffuse\"/></bsdf></bsdf>") +
        shape("<bsdf type=\"bumpmap\">" + tex + "<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></bsdf>") +
        shape("<bsdf type=\"bumpmap\">" + tex + "<bsdf type=\"dielectric\"/></bsdf>");
    Scene s = load_quiet(d.write("ok.xml", scene_text(forms)));
    ASSERT_EQ(s.meshes.size(), 5u);
    for (const Mesh& m : s.meshes) {
        const Bsdf& b = s.bsdfs[m.bsdf];
        EXPECT_GE(b.tex_bump, 0);
        EXPECT_TRUE(b.textured);
    }
    // A bump alone leaves the BSDF's parameters constant: scene_bsdf_at returns it by reference.
    EXPECT_FALSE(s.bsdfs[s.meshes[0].bsdf].textured_params);
    EXPECT_EQ(s.bsdfs[s.meshes[1].bsdf].type, BsdfType::RoughPlastic);
    EXPECT_TRUE(s.bsdfs[s.meshes[2].bsdf].two_sided);
    EXPECT_TRUE(s.bsdfs[s.meshes[3].bsdf].two_sided);
    EXPECT_EQ(s.bsdfs[s.meshes[4].bsdf].type, BsdfType::Dielectric);

    // A bitmap deeper inside (in a scale) without a gamma is read as Mitsuba reads it, with a warning.
    std::vector<std::string> warnings;
    SceneLoadOptions o;
    o.warnings = &warnings;
    load_scene(d.write("deep.xml", scene_text(shape(
                   "<bsdf type=\"bumpmap\"><texture type=\"scale\"><float name=\"scale\" value=\"0.1\"/><texture type=\"bitmap\">"
                   "<string name=\"filename\" value=\"ramp.png\"/></texture></texture><bsdf type=\"diffuse\"/></bsdf>"))),
               o);
    int gamma_warnings = 0;
    for (const std::string& w : warnings) gamma_warnings += w.find("height-map bitmap without an explicit gamma") != std::string::npos;
    EXPECT_EQ(gamma_warnings, 1);

    auto expect_error = [&](const std::string& body, const std::string& fragment) {
        const std::string path = d.write("bad.xml", scene_text(body));
        try {
            load_quiet(path);
            ADD_FAILURE() << "no error for: " << body;
        } catch (const std::exception& e) {
            EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("bad.xml:"), std::string::npos) << e.what();
        }
    };
    expect_error(shape("<bsdf type=\"bumpmap\"><texture type=\"bitmap\"><string name=\"filename\" value=\"ramp.png\"/></texture>"
                       "<bsdf type=\"diffuse\"/></bsdf>"),
                 "needs an explicit gamma");
    expect_error(shape("<bsdf type=\"bumpmap\"><bsdf type=\"diffuse\"/></bsdf>"), "bumpmap needs a displacement <texture>");
    expect_error(shape("<bsdf type=\"bumpmap\">" + tex + "</bsdf>"), "bumpmap needs a nested <bsdf> or <ref>");
    expect_error(shape("<bsdf type=\"bumpmap\">" + tex + "<bsdf type=\"bumpmap\">" + tex + "<bsdf type=\"diffuse\"/></bsdf></bsdf>"),
                 "a bumpmap inside a bumpmap");
    expect_error(shape("<bsdf type=\"bumpmap\">" + tex + tex + "<bsdf type=\"diffuse\"/></bsdf>"), "exactly one displacement");
    expect_error(shape("<bsdf type=\"bumpmap\">" + tex + "<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf>"),
                 "exactly one nested");
    // Mitsuba 0.5's bumpmap reads no `scale` (that is the scale texture's): unread, a warning naming it
    // (as Mitsuba's "Unqueried attribute"), and with --strict an error.
    const std::string scaled = d.write("scaled.xml", scene_text(shape("<bsdf type=\"bumpmap\"><float name=\"scale\" value=\"2\"/>" +
                                                                      tex + "<bsdf type=\"diffuse\"/></bsdf>")));
    std::vector<std::string> unread;
    SceneLoadOptions lenient;
    lenient.warnings = &unread;
    EXPECT_NO_THROW(load_scene(scaled, lenient));
    int scale_warnings = 0;
    for (const std::string& w : unread)
        scale_warnings += w.find("scaled.xml:") != std::string::npos &&
                          w.find("parameter \"scale\" of bsdf \"bumpmap\" is not read") != std::string::npos;
    EXPECT_EQ(scale_warnings, 1);
    SceneLoadOptions strict = lenient;
    strict.strict = true;
    EXPECT_THROW(load_scene(scaled, strict), SceneError);
}

// The bilinear gradient is the interpolant's derivative (against a central difference of texture_eval),
// with the texture's uv scale; nearest lookups and the checkerboard have none.
TEST(BumpMap, TextureGradientIsTheInterpolantsDerivative) {
    Texture t;
    t.width = 3;
    t.height = 2;
    t.texels = {RGB(0.1f), RGB(0.7f), RGB(0.3f), RGB(0.9f, 0.2f, 0.4f), RGB(0.0f), RGB(0.5f)};
    t.uscale = 2.0f;
    t.voffset = 0.1f;
    for (Vec2 uv : {Vec2{0.13f, 0.31f}, Vec2{0.41f, 0.77f}, Vec2{0.9f, 0.05f}}) {
        RGB du, dv;
        texture_gradient(t, uv, &du, &dv);
        const float e = 1e-3f;
        const RGB fu = (texture_eval(t, {uv.x + e, uv.y}) - texture_eval(t, {uv.x - e, uv.y})) / (2 * e);
        const RGB fv = (texture_eval(t, {uv.x, uv.y + e}) - texture_eval(t, {uv.x, uv.y - e})) / (2 * e);
        expect_rgb(du, fu, 2e-2f);
        expect_rgb(dv, fv, 2e-2f);
    }
    t.filter = TextureFilter::Nearest;
    RGB du, dv;
    texture_gradient(t, {0.4f, 0.4f}, &du, &dv);
    EXPECT_TRUE(is_black(du) && is_black(dv));
    Texture c;
    c.type = TextureType::Checkerboard;
    texture_gradient(c, {0.4f, 0.4f}, &du, &dv);
    EXPECT_TRUE(is_black(du) && is_black(dv));
}

}  // namespace
}  // namespace iris
