// The Mitsuba scene loader: every seed scene loads unchanged with the right content and camera
// conventions; small hand-written scenes check shapes, transforms, parameters and the fingerprint;
// and each kind of bad input fails with a message naming the file and the right line.
//
// Most tests use parse_scene (no Scene::finalize), so that they run while the BSDF and light code is
// being written; LoaderFinalize.* calls load_scene and needs that code.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "formats/scene_xml.h"
#include "libcommon/spectrum.h"

using namespace iris;
namespace fs = std::filesystem;

namespace {

const std::string kSeed = std::string(IRIS_SOURCE_DIR) + "/scenes/thesis/";

// Strict (an unread parameter is an error: the seed scenes have none, and the error cases below rely on
// it; test_scene_loader_tolerance.cpp has the default, warning behaviour) and with Mitsuba 0.5.0's
// spectrum interpolation, with which the thesis's scenes and their measured values were made.
Scene parse_quiet(const std::string& path, std::vector<std::string>* warnings = nullptr,
                  const std::map<std::string, std::string>& params = {}) {
    std::vector<std::string> local;
    SceneLoadOptions opt;
    opt.warnings = warnings ? warnings : &local;
    opt.parameters = params;
    opt.strict = true;
    opt.spectrum_interpolation = SpectrumInterpolation::Mitsuba050;
    return parse_scene(path, opt);
}

// A fresh directory per test for generated scenes and meshes.
class TempDir {
public:
    TempDir() {
        static std::atomic<int> counter{0};
        path_ = fs::temp_directory_path() /
                ("iris_loader_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    std::string write(const std::string& name, const std::string& text) const {
        fs::path p = path_ / name;
        fs::create_directories(p.parent_path());
        std::ofstream(p, std::ios::binary) << text;
        return p.string();
    }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

// 1-based line of the first line containing `marker`.
int line_of(const std::string& text, const std::string& marker) {
    size_t at = text.find(marker);
    EXPECT_NE(at, std::string::npos) << marker;
    return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

const char* kSensor = R"(  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="toWorld"><lookAt origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
  </sensor>
)";

std::string scene_text(const std::string& body) {
    return std::string("<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n") + kSensor + body + "</scene>\n";
}

const char* kQuadObj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n";

// Expects parse_scene(path) to throw a SceneError whose message starts with "path:line:" and
// contains `fragment`.
void expect_error(const std::string& path, int line, const std::string& fragment) {
    try {
        parse_quiet(path);
        ADD_FAILURE() << "no error for " << path << " (expected line " << line << ": " << fragment << ")";
    } catch (const SceneError& e) {
        std::string msg = e.what();
        std::string where = path + ":" + std::to_string(line) + ":";
        EXPECT_EQ(msg.rfind(where, 0), 0u) << "message: " << msg << "\nexpected to start with: " << where;
        EXPECT_NE(msg.find(fragment), std::string::npos) << "message: " << msg << "\nexpected to contain: " << fragment;
    }
}

const Mesh* mesh_named(const Scene& s, const std::string& name) {
    for (const Mesh& m : s.meshes)
        if (m.name == name) return &m;
    ADD_FAILURE() << "no mesh " << name;
    return nullptr;
}

void expect_rgb(RGB c, RGB want, float tol, const std::string& what = "") {
    EXPECT_NEAR(c.r, want.r, tol) << what;
    EXPECT_NEAR(c.g, want.g, tol) << what;
    EXPECT_NEAR(c.b, want.b, tol) << what;
}

Vec3 face_normal(const Mesh& m, uint32_t t) {
    const uint32_t* i = &m.indices[3 * t];
    return normalize(cross(m.positions[i[1]] - m.positions[i[0]], m.positions[i[2]] - m.positions[i[0]]));
}

struct SeedCounts {
    const char* file;
    size_t meshes, spheres, lights;
};
const SeedCounts kSeeds[] = {
    {"cbox_kugeln.xml", 6, 2, 1},          {"cbox_nur_box.xml", 6, 0, 1},
    {"cbox_spiegelboxen.xml", 8, 0, 1},    {"cbox_diffuse_boxes.xml", 8, 0, 1},
    {"veach_bidir/bidir.xml", 11, 0, 2},   {"veach_mi/mi.xml", 5, 5, 5},
    {"veach_mi/mi_ohne_bretter.xml", 1, 5, 5}, {"metal_ring/ring.xml", 2, 1, 1},
};

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Seed scenes

TEST(SceneLoader, EverySeedSceneParsesWithTheRightCounts) {
    for (const SeedCounts& c : kSeeds) {
        SCOPED_TRACE(c.file);
        std::vector<std::string> warnings;
        Scene s = parse_quiet(kSeed + c.file, &warnings);
        EXPECT_EQ(s.meshes.size(), c.meshes);
        EXPECT_EQ(s.spheres.size(), c.spheres);
        EXPECT_EQ(s.lights.size(), c.lights);
        EXPECT_EQ(s.source, kSeed + c.file);
        EXPECT_EQ(s.fingerprint.size(), 32u);
        for (const Mesh& m : s.meshes) {
            EXPECT_GT(m.triangle_count(), 0u);
            EXPECT_LT(m.bsdf, s.bsdfs.size());
            for (Vec3 p : m.positions) ASSERT_TRUE(is_finite(p));
            if (!m.normals.empty()) {
                ASSERT_EQ(m.normals.size(), m.positions.size());
            }
            for (uint32_t i : m.indices) ASSERT_LT(i, m.positions.size());
        }
        for (const Sphere& sp : s.spheres) EXPECT_LT(sp.bsdf, s.bsdfs.size());
        // Every light points back at its shape and vice versa.
        for (size_t i = 0; i < s.lights.size(); ++i) {
            const Light& l = s.lights[i];
            if (l.type == LightType::AreaMesh) {
                EXPECT_EQ(s.meshes.at(l.shape).light, int32_t(i));
            } else if (l.type == LightType::AreaSphere) {
                EXPECT_EQ(s.spheres.at(l.shape).light, int32_t(i));
            }
        }
    }
}

TEST(SceneLoader, SeedMeshTriangleCounts) {
    Scene bidir = parse_quiet(kSeed + "veach_bidir/bidir.xml");
    EXPECT_EQ(mesh_named(bidir, "Egg-Mesh-mesh_0")->triangle_count(), 2162u);  // as in the seed's log
    size_t total = 0;
    for (const Mesh& m : bidir.meshes) total += m.triangle_count();
    EXPECT_EQ(total, 3392u);
    Scene ring = parse_quiet(kSeed + "metal_ring/ring.xml");
    EXPECT_EQ(mesh_named(ring, "Circle_Circle_0000_m000-shape_0")->triangle_count(), 65536u);
    Scene cbox = parse_quiet(kSeed + "cbox_spiegelboxen.xml");
    EXPECT_EQ(mesh_named(cbox, "meshes/cbox_largebox.obj")->triangle_count(), 12u);
    EXPECT_EQ(mesh_named(cbox, "meshes/cbox_floor.obj")->triangle_count(), 2u);  // one quad, fan-split
}

TEST(SceneLoader, CornellBoxCameraImageRightIsMinusX) {
    Scene s = parse_quiet(kSeed + "cbox_kugeln.xml");
    const Camera& c = s.camera;
    EXPECT_EQ(s.film.width, 512);
    EXPECT_EQ(s.film.height, 512);
    EXPECT_EQ(c.fov_axis, FovAxis::Smaller);
    EXPECT_FLOAT_EQ(c.fov_degrees, 39.3077f);
    // Square image: "smaller" is either axis, both get the 39.3077 degrees.
    EXPECT_NEAR(c.tan_half_x, std::tan(0.5 * 39.3077 * M_PI / 180), 1e-6);
    EXPECT_NEAR(c.tan_half_y, c.tan_half_x, 1e-7);
    EXPECT_NEAR(c.origin.x, 278, 1e-3);
    EXPECT_NEAR(c.origin.z, -800, 1e-3);
    EXPECT_NEAR(c.near_clip, 10, 0);
    EXPECT_NEAR(c.far_clip, 2800, 0);
    // Mitsuba: image right = cross(target - origin, up) = -x, so the red wall (x = 556) is on the left.
    Vec3 right_edge = camera_direction(c, 512, 256, 512, 512);
    Vec3 left_edge = camera_direction(c, 0, 256, 512, 512);
    Vec3 top_edge = camera_direction(c, 256, 0, 512, 512);
    EXPECT_LT(right_edge.x, -0.3f);
    EXPECT_GT(left_edge.x, 0.3f);
    EXPECT_GT(top_edge.y, 0.3f);
    EXPECT_NEAR(c.forward.z, 1.0f, 1e-6f);
    // Gaussian filter, Mitsuba's defaults.
    EXPECT_EQ(s.film.filter, FilterType::Gaussian);
    EXPECT_FLOAT_EQ(s.film.filter_stddev, 0.5f);
    EXPECT_FLOAT_EQ(s.film.filter_radius, 2.0f);
    EXPECT_EQ(s.defaults.spp, 64);
    EXPECT_EQ(s.defaults.max_depth, -1);
    EXPECT_EQ(s.defaults.rr_depth, 5);
}

TEST(SceneLoader, VeachMiCameraMirrorScalesCancel) {
    Scene s = parse_quiet(kSeed + "veach_mi/mi.xml");
    const Camera& c = s.camera;
    Transform expected = Transform::look_at(Vec3(0, 2, 15), Vec3(0, -2, 2.5f), Vec3(0, 1, 0));
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) EXPECT_NEAR(c.to_world.m[i][j], expected.m[i][j], 1e-12) << i << "," << j;
    // 768x512 with fovAxis "smaller": the 28 degrees are vertical.
    EXPECT_NEAR(c.tan_half_y, std::tan(14.0 * M_PI / 180), 1e-6);
    EXPECT_NEAR(c.tan_half_x, c.tan_half_y * 1.5f, 1e-6);
    EXPECT_GT(camera_direction(c, 768, 256, 768, 512).x, 0.2f);  // cross(dir, up) = +x here
    EXPECT_EQ(s.defaults.spp, 16);
}

TEST(SceneLoader, CornellBoxEmittersAndReflectances) {
    Scene glass = parse_quiet(kSeed + "cbox_kugeln.xml");
    ASSERT_EQ(glass.lights.size(), 1u);
    EXPECT_EQ(glass.lights[0].type, LightType::AreaMesh);
    expect_rgb(glass.lights[0].radiance, RGB(36.813f, 21.336f, 5.542f), 2e-3f, "glass-sphere light");
    const Mesh* lum = mesh_named(glass, "meshes/cbox_luminaire.obj");
    // Scaled (0.5, 1, 0.5) then moved by (100, -10, 150): a 65 x 52.5 quad at y = 538.8 facing down.
    float xmin = 1e9f, xmax = -1e9f, zmin = 1e9f, zmax = -1e9f;
    for (Vec3 p : lum->positions) {
        xmin = std::min(xmin, p.x), xmax = std::max(xmax, p.x);
        zmin = std::min(zmin, p.z), zmax = std::max(zmax, p.z);
        EXPECT_NEAR(p.y, 538.8f, 1e-3f);
    }
    EXPECT_NEAR(xmax - xmin, 65.0f, 1e-3f);
    EXPECT_NEAR(zmax - zmin, 52.5f, 1e-3f);
    EXPECT_LT(face_normal(*lum, 0).y, -0.999f);
    const Bsdf& lum_bsdf = glass.bsdfs[lum->bsdf];
    expect_rgb(lum_bsdf.diffuse, RGB(0.9365f, 0.7404f, 0.7053f), 5e-4f, "luminaire reflectance");
    const Bsdf& white = glass.bsdfs[mesh_named(glass, "meshes/cbox_floor.obj")->bsdf];
    expect_rgb(white.diffuse, RGB(0.885809f, 0.698859f, 0.666422f), 5e-5f, "white");
    // The glass spheres: dielectric 1.9 against Mitsuba's default exterior "air".
    ASSERT_EQ(glass.spheres.size(), 2u);
    EXPECT_NEAR(glass.spheres[0].radius, 90.0f, 0);
    EXPECT_NEAR(glass.spheres[1].center.y, 450.0f, 0);
    const Bsdf& g = glass.bsdfs[glass.spheres[0].bsdf];
    EXPECT_EQ(g.type, BsdfType::Dielectric);
    EXPECT_NEAR(g.ior, 1.9f / 1.00028f, 1e-6f);

    Scene empty = parse_quiet(kSeed + "cbox_nur_box.xml");
    expect_rgb(empty.lights[0].radiance, RGB(18.387f, 10.987f, 2.754f), 2e-3f, "standard light");
    const Mesh* lum2 = mesh_named(empty, "meshes/cbox_luminaire.obj");
    for (Vec3 p : lum2->positions) EXPECT_NEAR(p.y, 548.3f, 1e-3f);
}

TEST(SceneLoader, MirrorBoxConductorDefaultsToCopper) {
    std::vector<std::string> warnings;
    Scene s = parse_quiet(kSeed + "cbox_spiegelboxen.xml", &warnings);
    const Bsdf& b = s.bsdfs[mesh_named(s, "meshes/cbox_smallbox.obj")->bsdf];
    EXPECT_EQ(b.type, BsdfType::Conductor);
    EXPECT_EQ(mesh_named(s, "meshes/cbox_largebox.obj")->bsdf, mesh_named(s, "meshes/cbox_smallbox.obj")->bsdf);
    RGB eta, k;
    ASSERT_TRUE(conductor_ior("Cu", &eta, &k));
    expect_rgb(b.eta, eta / 1.00028f, 1e-6f, "eta relative to air");
    expect_rgb(b.k, k / 1.00028f, 1e-6f, "k relative to air");
    expect_rgb(b.specular, RGB(1.0f), 0, "specularReflectance");
    // The reflectance spectrum on the conductor is ignored, as Mitsuba does, with a warning.
    bool warned = false;
    for (const std::string& w : warnings)
        warned = warned || (w.find("\"reflectance\"") != std::string::npos && w.find("conductor") != std::string::npos &&
                            w.find("Mitsuba") != std::string::npos);
    EXPECT_TRUE(warned);
}

TEST(SceneLoader, BidirMaterialsAndLights) {
    std::vector<std::string> warnings;
    Scene s = parse_quiet(kSeed + "veach_bidir/bidir.xml", &warnings);
    const Bsdf& glass = s.bsdfs[mesh_named(s, "Egg-Mesh-mesh_0")->bsdf];
    EXPECT_EQ(glass.type, BsdfType::Dielectric);
    EXPECT_FLOAT_EQ(glass.ior, 1.5f);
    const Bsdf& lamp = s.bsdfs[mesh_named(s, "Lamp1Exterior-mesh_0")->bsdf];
    EXPECT_EQ(lamp.type, BsdfType::Ward);
    EXPECT_EQ(lamp.ward_variant, WardVariant::Balanced);
    EXPECT_FLOAT_EQ(lamp.alpha_u, 0.4f);
    EXPECT_FLOAT_EQ(lamp.alpha_v, 0.4f);
    expect_rgb(lamp.specular, RGB(0.616f, 0.4752f, 0.352f), 1e-6f, "ward specular");
    expect_rgb(lamp.diffuse, RGB(0.0f), 0, "ward diffuse");
    EXPECT_EQ(mesh_named(s, "Lamp1Exterior_001-mesh_0")->bsdf, mesh_named(s, "Lamp1Exterior-mesh_0")->bsdf);
    const Bsdf& wood = s.bsdfs[mesh_named(s, "TableTop-Mesh-mesh_0")->bsdf];
    expect_rgb(wood.diffuse, RGB(0.32962962985f, 0.257976263762f, 0.150291711092f), 1e-7f, "wood");
    const Bsdf& cyl = s.bsdfs[mesh_named(s, "Cylinder_004-mesh_0")->bsdf];
    EXPECT_EQ(cyl.type, BsdfType::Diffuse);
    expect_rgb(cyl.diffuse, RGB(0.5f), 0, "default diffuse");

    const Mesh* spot = mesh_named(s, "Lamp2Luminaire-mesh_0");
    const Mesh* floor_lamp = mesh_named(s, "Lamp1Luminaire-mesh_0");
    ASSERT_GE(spot->light, 0);
    ASSERT_GE(floor_lamp->light, 0);
    expect_rgb(s.lights[size_t(spot->light)].radiance, RGB(6999.999881f, 5450.000167f, 3630.000055f), 1e-2f, "spot");
    expect_rgb(s.lights[size_t(floor_lamp->light)].radiance, RGB(500.0f), 0, "floor lamp");
    EXPECT_FLOAT_EQ(s.lights[size_t(spot->light)].sampling_weight, 1.0f);
    // The floor-lamp luminaire faces +z (up, at the ceiling).
    EXPECT_GT(face_normal(*floor_lamp, 0).z, 0.99f);
    // Mesh normals are transformed to world space and unit length.
    for (Vec3 n : floor_lamp->normals) EXPECT_NEAR(n.z, 1.0f, 1e-4f);

    EXPECT_EQ(s.defaults.max_depth, 6);
    EXPECT_EQ(s.film.width, 768);
    EXPECT_EQ(s.film.height, 576);
    EXPECT_EQ(s.camera.fov_axis, FovAxis::X);
    EXPECT_NEAR(s.camera.tan_half_x, std::tan(0.5 * 44.5513 * M_PI / 180), 1e-6);
    bool medium_warned = false;
    for (const std::string& w : warnings) medium_warned = medium_warned || w.find("medium") != std::string::npos;
    EXPECT_TRUE(medium_warned);
}

TEST(SceneLoader, VeachMiPlatesAndSphereLights) {
    Scene s = parse_quiet(kSeed + "veach_mi/mi.xml");
    const float alphas[4] = {0.005f, 0.02f, 0.05f, 0.1f};
    for (int i = 0; i < 4; ++i) {
        const Bsdf& b = s.bsdfs[mesh_named(s, "plate" + std::to_string(i + 1) + ".obj")->bsdf];
        EXPECT_EQ(b.type, BsdfType::RoughPlastic);
        EXPECT_EQ(b.distribution, Microfacet::Beckmann);
        EXPECT_FLOAT_EQ(b.alpha_u, alphas[i]);
        EXPECT_FLOAT_EQ(b.alpha_v, alphas[i]);
        EXPECT_NEAR(b.ior, 2.0f / 1.00028f, 1e-6f);
        expect_rgb(b.diffuse, RGB(0.07f, 0.09f, 0.13f), 1e-7f, "plate diffuse");
        expect_rgb(b.specular, RGB(1.0f), 0, "plate specular");
        EXPECT_FALSE(b.nonlinear);
    }
    const float radius[5] = {0.5f, 0.1f, 0.03333f, 0.3f, 0.9f};
    const float radiance[5] = {800.0f, 100.0f, 901.803f, 11.1111f, 1.23457f};
    for (int i = 0; i < 5; ++i) {
        const Sphere& sp = s.spheres[size_t(i)];
        EXPECT_FLOAT_EQ(sp.radius, radius[i]);
        ASSERT_GE(sp.light, 0);
        const Light& l = s.lights[size_t(sp.light)];
        EXPECT_EQ(l.type, LightType::AreaSphere);
        EXPECT_EQ(l.shape, uint32_t(i));
        expect_rgb(l.radiance, RGB(radiance[i]), 1e-3f, "sphere light");
        expect_rgb(s.bsdfs[sp.bsdf].diffuse, RGB(0.0f), 0, "black sphere");
    }
    EXPECT_FLOAT_EQ(s.spheres[2].center.x, -3.75f);
    EXPECT_FLOAT_EQ(s.bsdfs[mesh_named(s, "floor.obj")->bsdf].diffuse.g, 0.4f);
}

TEST(SceneLoader, MetalRing) {
    Scene s = parse_quiet(kSeed + "metal_ring/ring.xml");
    const Bsdf& metal = s.bsdfs[mesh_named(s, "Circle_Circle_0000_m000-shape_0")->bsdf];
    EXPECT_EQ(metal.type, BsdfType::Conductor);
    expect_rgb(metal.eta, RGB(0.37f), 1e-7f, "eta");
    expect_rgb(metal.k, RGB(2.82f), 1e-7f, "k");
    expect_rgb(metal.specular, RGB(1.0f, 0.139732f, 0.063244f), 1e-7f, "tint");
    const Bsdf& plane = s.bsdfs[mesh_named(s, "Plane_Plane_0000_m000-shape_0")->bsdf];
    EXPECT_EQ(plane.type, BsdfType::RoughDiffuse);
    EXPECT_FLOAT_EQ(plane.alpha_u, 0.74f);
    expect_rgb(plane.diffuse, RGB(0.685959f), 1e-7f, "plane");
    EXPECT_EQ(s.defaults.max_depth, 24);
    EXPECT_EQ(s.defaults.rr_depth, 32);
    EXPECT_EQ(s.defaults.spp, 128);
    EXPECT_EQ(s.film.width, 960);
    ASSERT_EQ(s.spheres.size(), 1u);
    EXPECT_NEAR(s.spheres[0].radius, 0.2f, 1e-7f);
    EXPECT_GE(s.spheres[0].light, 0);
    // The plane (matrix: scale 2.395769, rotate, shift) is horizontal, at y = 0 in world space.
    for (Vec3 p : mesh_named(s, "Plane_Plane_0000_m000-shape_0")->positions) EXPECT_NEAR(p.y, 0.0f, 1e-6f);
}

TEST(SceneLoader, FingerprintIdentifiesContentNotLocation) {
    TempDir a, b;
    std::string text = scene_text(R"(  <shape type="obj"><string name="filename" value="quad.obj"/></shape>
)");
    std::string pa = a.write("scene.xml", text), pb = b.write("scene.xml", text);
    a.write("quad.obj", kQuadObj);
    b.write("quad.obj", kQuadObj);
    const std::string fa = parse_quiet(pa).fingerprint;
    EXPECT_EQ(fa, parse_quiet(pb).fingerprint);  // same bytes elsewhere: same scene
    b.write("quad.obj", std::string(kQuadObj) + "# a comment changes the bytes\n");
    EXPECT_NE(fa, parse_quiet(pb).fingerprint);  // the mesh bytes count
    EXPECT_NE(fa, parse_quiet(pa, nullptr, {{"unused", "1"}}).fingerprint);  // so do parameter overrides
    for (char c : fa) EXPECT_TRUE(std::isxdigit(static_cast<unsigned char>(c)));
}

// ---------------------------------------------------------------------------------------------------
// Features on small scenes

TEST(SceneLoader, ParametersDefaultsAndOverrides) {
    TempDir d;
    std::string path = d.write("scene.xml", R"(<scene version="0.5.0">
  <default name="spp" value="8"/>
  <default name="rad" value="2.5"/>
  <integrator type="path"><integer name="maxDepth" value="$depth"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="30"/>
    <sampler type="independent"><integer name="sampleCount" value="$spp"/></sampler>
  </sensor>
  <shape type="sphere"><float name="radius" value="$rad"/></shape>
</scene>
)");
    Scene s = parse_quiet(path, nullptr, {{"depth", "7"}});
    EXPECT_EQ(s.defaults.spp, 8);
    EXPECT_EQ(s.defaults.max_depth, 7);
    EXPECT_FLOAT_EQ(s.spheres[0].radius, 2.5f);
    Scene t = parse_quiet(path, nullptr, {{"depth", "3"}, {"spp", "32"}});
    EXPECT_EQ(t.defaults.spp, 32);
    EXPECT_EQ(t.defaults.max_depth, 3);
    // Without a value for $depth it is an error on the integrator's line.
    expect_error(path, 4, "$depth");
}

TEST(SceneLoader, TransformsApplyInListedOrder) {
    TempDir d;
    d.write("quad.obj", kQuadObj);
    std::string path = d.write("scene.xml", scene_text(R"(  <shape type="obj" id="a">
    <string name="filename" value="quad.obj"/>
    <transform name="toWorld">
      <scale x="2"/>
      <rotate z="1" angle="90"/>
      <translate x="10" y="20"/>
    </transform>
  </shape>
  <shape type="obj" id="b">
    <string name="filename" value="quad.obj"/>
    <transform name="toWorld">
      <matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/>
      <scale value="3"/>
    </transform>
  </shape>
)"));
    Scene s = parse_quiet(path);
    // (1, -1, 0) -> scale x2 -> (2, -1, 0) -> rotate 90 about z -> (1, 2, 0) -> translate -> (11, 22, 0).
    const Mesh* a = mesh_named(s, "a");
    bool found = false;
    for (Vec3 p : a->positions)
        found = found || (std::abs(p.x - 11) < 1e-5f && std::abs(p.y - 22) < 1e-5f && std::abs(p.z) < 1e-5f);
    EXPECT_TRUE(found);
    // Translate first, then scale: the translation is scaled too.
    const Mesh* b = mesh_named(s, "b");
    for (Vec3 p : b->positions) EXPECT_NEAR(p.z, 21.0f, 1e-5f);
}

TEST(SceneLoader, ObjTriangulationNormalsAndDegenerates) {
    TempDir d;
    // A quad (fan-split), a pentagon, a degenerate triangle, two groups, negative indices, normals.
    d.write("m.obj", R"(# test mesh
o first
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vn 0 0 1
vn 0 0 1
vn 0 0 1
vn 0 0 1
f 1//1 2//2 3//3 4//4
g second
v 2 0 0
v 3 0 0
v 4 1 0
v 3 2 0
v 2 1 0
vn 0 0 2
f -5//-1 -4//-1 -3//-1 -2//-1 -1//-1
f 1//1 2//2 1//1
)");
    std::vector<std::string> warnings;
    std::string path = d.write("scene.xml", scene_text(R"(  <shape type="obj" id="m">
    <string name="filename" value="m.obj"/>
    <transform name="toWorld"><scale x="2" y="1" z="1"/></transform>
  </shape>
  <shape type="obj" id="flat">
    <string name="filename" value="m.obj"/>
    <boolean name="faceNormals" value="true"/>
    <boolean name="flipNormals" value="true"/>
  </shape>
)"));
    Scene s = parse_quiet(path, &warnings);
    const Mesh* m = mesh_named(s, "m");
    EXPECT_EQ(m->triangle_count(), 2u + 3u);  // quad -> 2, pentagon -> 3, degenerate skipped
    ASSERT_EQ(m->normals.size(), m->positions.size());
    for (Vec3 n : m->normals) {
        EXPECT_NEAR(n.z, 1.0f, 1e-6f);
        EXPECT_NEAR(length(n), 1.0f, 1e-6f);
    }
    for (uint32_t t = 0; t < m->triangle_count(); ++t) EXPECT_GT(face_normal(*m, t).z, 0.99f);
    bool warned = false;
    for (const std::string& w : warnings) warned = warned || w.find("1 degenerate") != std::string::npos;
    EXPECT_TRUE(warned);
    const Mesh* flat = mesh_named(s, "flat");
    EXPECT_TRUE(flat->normals.empty());
    EXPECT_TRUE(flat->flip_normals);
    EXPECT_FALSE(m->flip_normals);
}

TEST(SceneLoader, NormalsUseTheInverseTransposeAndMirrorsKeepTheWinding) {
    TempDir d;
    // A 45-degree slope with its true normal; a non-uniform scale must keep it perpendicular.
    d.write("slope.obj", "v 0 0 0\nv 1 1 0\nv 0 0 1\nvn 0.70710678 -0.70710678 0\nf 1//1 2//1 3//1\n");
    std::string path = d.write("scene.xml", scene_text(R"(  <shape type="obj" id="s">
    <string name="filename" value="slope.obj"/>
    <transform name="toWorld"><scale x="3"/></transform>
  </shape>
  <shape type="obj" id="mirror">
    <string name="filename" value="slope.obj"/>
    <transform name="toWorld"><scale x="-1"/></transform>
  </shape>
)"));
    Scene s = parse_quiet(path);
    for (const char* id : {"s", "mirror"}) {
        SCOPED_TRACE(id);
        const Mesh* m = mesh_named(s, id);
        Vec3 edge = m->positions[m->indices[1]] - m->positions[m->indices[0]];
        Vec3 n = m->normals[0];
        EXPECT_NEAR(dot(n, normalize(edge)), 0.0f, 1e-6f);
        EXPECT_NEAR(length(n), 1.0f, 1e-6f);
        // The geometric normal (winding) and the shading normal agree, also under the mirror.
        EXPECT_GT(dot(face_normal(*m, 0), n), 0.99f);
    }
}

TEST(SceneLoader, ObjWithoutNormalsGetsSmoothNormalsUnlessFaceNormals) {
    TempDir d;
    // Two faces of a roof sharing an edge: the shared vertices get the averaged normal.
    d.write("roof.obj", "v 0 0 0\nv 1 1 0\nv 0 0 1\nv 1 1 1\nv 2 0 0\nv 2 0 1\nf 1 2 4 3\nf 2 5 6 4\n");
    std::string path = d.write("scene.xml", scene_text(R"(  <shape type="obj" id="smooth"><string name="filename" value="roof.obj"/></shape>
  <shape type="obj" id="flat"><string name="filename" value="roof.obj"/><boolean name="faceNormals" value="true"/></shape>
)"));
    Scene s = parse_quiet(path);
    const Mesh* smooth = mesh_named(s, "smooth");
    ASSERT_EQ(smooth->normals.size(), 6u);
    int ridge = 0;
    for (size_t i = 0; i < 6; ++i)
        if (std::abs(smooth->positions[i].x - 1) < 1e-6f) {
            ++ridge;
            EXPECT_NEAR(std::abs(smooth->normals[i].y), 1.0f, 1e-5f);  // average of the two slopes
        }
    EXPECT_EQ(ridge, 2);
    EXPECT_TRUE(mesh_named(s, "flat")->normals.empty());
}

TEST(SceneLoader, AnalyticShapes) {
    TempDir d;
    std::string path = d.write("scene.xml", scene_text(R"(  <shape type="rectangle" id="rect">
    <transform name="toWorld"><scale value="2"/><translate z="3"/></transform>
    <emitter type="area"><rgb name="radiance" value="1, 2, 3"/><float name="samplingWeight" value="2"/></emitter>
  </shape>
  <shape type="cube" id="cube"><transform name="toWorld"><translate x="10"/></transform></shape>
  <shape type="sphere">
    <point name="center" x="1" y="2" z="3"/>
    <float name="radius" value="0.5"/>
    <transform name="toWorld"><scale value="4"/><translate x="1"/></transform>
    <boolean name="flipNormals" value="true"/>
    <bsdf type="twosided"><bsdf type="diffuse"><srgb name="reflectance" value="#ff8000"/></bsdf></bsdf>
  </shape>
  <emitter type="point"><point name="position" x="0" y="5" z="0"/><spectrum name="intensity" value="100"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
)"));
    Scene s = parse_quiet(path);
    const Mesh* rect = mesh_named(s, "rect");
    EXPECT_EQ(rect->triangle_count(), 2u);
    for (Vec3 p : rect->positions) {
        EXPECT_NEAR(std::abs(p.x), 2.0f, 1e-6f);
        EXPECT_NEAR(p.z, 3.0f, 1e-6f);
    }
    EXPECT_GT(face_normal(*rect, 0).z, 0.99f);  // faces +z
    ASSERT_GE(rect->light, 0);
    EXPECT_EQ(s.lights[size_t(rect->light)].type, LightType::AreaMesh);
    expect_rgb(s.lights[size_t(rect->light)].radiance, RGB(1, 2, 3), 0);
    EXPECT_FLOAT_EQ(s.lights[size_t(rect->light)].sampling_weight, 2.0f);
    EXPECT_TRUE(rect->normals.empty());

    const Mesh* cube = mesh_named(s, "cube");
    ASSERT_EQ(cube->triangle_count(), 12u);
    for (uint32_t t = 0; t < 12; ++t) {
        const uint32_t* i = &cube->indices[3 * t];
        Vec3 centroid = (cube->positions[i[0]] + cube->positions[i[1]] + cube->positions[i[2]]) / 3.0f;
        EXPECT_GT(dot(face_normal(*cube, t), centroid - Vec3(10, 0, 0)), 0.0f) << "outward, triangle " << t;
    }

    ASSERT_EQ(s.spheres.size(), 1u);
    EXPECT_NEAR(s.spheres[0].radius, 2.0f, 1e-6f);  // 0.5 * 4
    EXPECT_NEAR(s.spheres[0].center.x, 5.0f, 1e-5f);  // (1 * 4) + 1
    EXPECT_NEAR(s.spheres[0].center.z, 12.0f, 1e-5f);
    EXPECT_TRUE(s.spheres[0].flip_normals);
    const Bsdf& b = s.bsdfs[s.spheres[0].bsdf];
    EXPECT_TRUE(b.two_sided);
    expect_rgb(b.diffuse, RGB(1.0f, srgb_to_linear(128.0f / 255.0f), 0.0f), 1e-6f, "srgb");

    ASSERT_EQ(s.lights.size(), 3u);
    EXPECT_EQ(s.lights[1].type, LightType::Point);
    EXPECT_FLOAT_EQ(s.lights[1].position.y, 5.0f);
    expect_rgb(s.lights[1].radiance, RGB(100.0f), 0);
    EXPECT_EQ(s.lights[2].type, LightType::Constant);
    EXPECT_EQ(s.environment_light, 2);
}

TEST(SceneLoader, BsdfParameterNamesAndDefaults) {
    TempDir d;
    d.write("quad.obj", kQuadObj);
    auto shape = [](const std::string& id, const std::string& bsdf) {
        return "  <shape type=\"obj\" id=\"" + id + "\"><string name=\"filename\" value=\"quad.obj\"/>\n    " + bsdf +
               "\n  </shape>\n";
    };
    std::string body = shape("diffuse", R"(<bsdf type="diffuse"/>)") +
                       shape("glass", R"(<bsdf type="dielectric"><string name="intIOR" value="water"/><float name="extIOR" value="1.0"/></bsdf>)") +
                       shape("glassdef", R"(<bsdf type="dielectric"/>)") +
                       shape("pane", R"(<bsdf type="thindielectric"><float name="intIOR" value="1.52"/><rgb name="specularTransmittance" value="0.9, 0.8, 0.7"/></bsdf>)") +
                       shape("frosted", R"(<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/><float name="intIOR" value="1.33"/><float name="extIOR" value="1.0"/><rgb name="specularTransmittance" value="0.9, 0.8, 0.7"/><boolean name="sampleVisible" value="true"/></bsdf>)") +
                       shape("frosteddef", R"(<bsdf type="roughdielectric"/>)") +
                       shape("gold", R"(<bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/><float name="alphaU" value="0.1"/><float name="alphaV" value="0.3"/></bsdf>)") +
                       shape("plastic", R"(<bsdf type="plastic"><boolean name="nonlinear" value="true"/></bsdf>)") +
                       shape("rough", R"(<bsdf type="roughplastic"/>)") +
                       shape("ward", R"(<bsdf type="ward"><string name="variant" value="ward-duer"/><float name="alphaU" value="0.2"/><float name="alphaV" value="0.4"/></bsdf>)") +
                       shape("none", R"(<bsdf type="conductor"><string name="material" value="none"/></bsdf>)") +
                       shape("nobsdf", "");
    std::string path = d.write("scene.xml", scene_text(body));
    Scene s = parse_quiet(path);
    auto bsdf = [&](const char* id) -> const Bsdf& { return s.bsdfs[mesh_named(s, id)->bsdf]; };
    expect_rgb(bsdf("diffuse").diffuse, RGB(0.5f), 0);
    EXPECT_NEAR(bsdf("glass").ior, 1.333f, 1e-6f);
    EXPECT_NEAR(bsdf("glassdef").ior, 1.5046f / 1.00028f, 1e-6f);  // bk7 in air
    const Bsdf& pane = bsdf("pane");
    EXPECT_EQ(pane.type, BsdfType::ThinDielectric);
    EXPECT_NEAR(pane.ior, 1.52f / 1.00028f, 1e-6f);
    expect_rgb(pane.specular, RGB(1.0f), 0);
    expect_rgb(pane.transmittance, RGB(0.9f, 0.8f, 0.7f), 1e-6f);
    const Bsdf& frosted = bsdf("frosted");
    EXPECT_EQ(frosted.type, BsdfType::RoughDielectric);
    EXPECT_EQ(frosted.distribution, Microfacet::GGX);
    EXPECT_FLOAT_EQ(frosted.alpha_u, 0.2f);
    EXPECT_FLOAT_EQ(frosted.alpha_v, 0.2f);
    EXPECT_NEAR(frosted.ior, 1.33f, 1e-6f);
    expect_rgb(frosted.transmittance, RGB(0.9f, 0.8f, 0.7f), 1e-6f);
    // Mitsuba's defaults: Beckmann, alpha 0.1, bk7 in air.
    const Bsdf& frosteddef = bsdf("frosteddef");
    EXPECT_EQ(frosteddef.distribution, Microfacet::Beckmann);
    EXPECT_FLOAT_EQ(frosteddef.alpha_u, 0.1f);
    EXPECT_NEAR(frosteddef.ior, 1.5046f / 1.00028f, 1e-6f);
    const Bsdf& gold = bsdf("gold");
    EXPECT_EQ(gold.type, BsdfType::RoughConductor);
    EXPECT_EQ(gold.distribution, Microfacet::GGX);
    EXPECT_FLOAT_EQ(gold.alpha_u, 0.1f);
    EXPECT_FLOAT_EQ(gold.alpha_v, 0.3f);
    RGB eta, k;
    conductor_ior("Au", &eta, &k);
    expect_rgb(gold.eta, eta / 1.00028f, 1e-6f);
    const Bsdf& plastic = bsdf("plastic");
    EXPECT_EQ(plastic.type, BsdfType::Plastic);
    EXPECT_TRUE(plastic.nonlinear);
    EXPECT_NEAR(plastic.ior, 1.49f / 1.00028f, 1e-6f);  // polypropylene in air
    expect_rgb(plastic.diffuse, RGB(0.5f), 0);
    const Bsdf& rough = bsdf("rough");
    EXPECT_EQ(rough.distribution, Microfacet::Beckmann);
    EXPECT_FLOAT_EQ(rough.alpha_u, 0.1f);
    const Bsdf& ward = bsdf("ward");
    EXPECT_EQ(ward.ward_variant, WardVariant::WardDuer);
    EXPECT_FLOAT_EQ(ward.alpha_u, 0.2f);
    EXPECT_FLOAT_EQ(ward.alpha_v, 0.4f);
    expect_rgb(ward.specular, RGB(0.2f), 0);
    expect_rgb(bsdf("none").eta, RGB(0.0f), 0);
    expect_rgb(bsdf("none").k, RGB(1.0f / 1.00028f), 1e-6f);
    EXPECT_EQ(bsdf("nobsdf").type, BsdfType::Diffuse);
    expect_rgb(bsdf("nobsdf").diffuse, RGB(0.5f), 0);
}

TEST(SceneLoader, SpectrumValueForms) {
    TempDir d;
    d.write("quad.obj", kQuadObj);
    std::string body;
    const char* values[] = {"0.25", "0.1 0.2 0.3", "0.1, 0.2, 0.3", "400:0, 500:8, 600:15.6, 700:18.4"};
    for (int i = 0; i < 4; ++i)
        body += "  <shape type=\"obj\" id=\"s" + std::to_string(i) +
                "\"><string name=\"filename\" value=\"quad.obj\"/><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"" +
                values[i] + "\"/></bsdf></shape>\n";
    Scene s = parse_quiet(d.write("scene.xml", scene_text(body)));
    const char* ids[] = {"s0", "s1", "s2", "s3"};
    auto refl = [&](int i) { return s.bsdfs[mesh_named(s, ids[i])->bsdf].diffuse; };
    expect_rgb(refl(0), RGB(0.25f), 0);
    expect_rgb(refl(1), RGB(0.1f, 0.2f, 0.3f), 0);
    expect_rgb(refl(2), RGB(0.1f, 0.2f, 0.3f), 0);
    expect_rgb(refl(3), RGB(18.387f, 10.987f, 2.754f), 2e-3f);
}

TEST(SceneLoader, IncludeAndRefToInlineBsdf) {
    TempDir d;
    d.write("parts/quad.obj", kQuadObj);
    d.write("parts/part.xml", R"(<scene version="0.5.0">
  <shape type="obj" id="inc"><string name="filename" value="quad.obj"/><bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8 0 0"/></bsdf></shape>
</scene>
)");
    std::string path = d.write("scene.xml", scene_text(R"(  <include filename="parts/part.xml"/>
  <shape type="obj" id="again"><string name="filename" value="parts/quad.obj"/><ref id="red"/></shape>
)"));
    Scene s = parse_quiet(path);
    EXPECT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(mesh_named(s, "inc")->bsdf, mesh_named(s, "again")->bsdf);
    expect_rgb(s.bsdfs[mesh_named(s, "again")->bsdf].diffuse, RGB(0.8f, 0, 0), 0);
}

TEST(SceneLoader, WarningsGoToTheCallersList) {
    TempDir d;
    std::string text = scene_text(R"(  <integrator type="path"><boolean name="strictNormals" value="true"/></integrator>
  <shape type="sphere"/>
)");
    std::string path = d.write("scene.xml", text);
    std::vector<std::string> warnings;
    parse_quiet(path, &warnings);
    bool found = false;
    std::string where = path + ":" + std::to_string(line_of(text, "strictNormals")) + ": ";
    for (const std::string& w : warnings)
        found = found || (w.rfind(where, 0) == 0 && w.find("strictNormals") != std::string::npos);
    EXPECT_TRUE(found);
}

// ---------------------------------------------------------------------------------------------------
// Bad input: every error names the file and the line.

TEST(SceneLoaderErrors, MalformedXml) {
    TempDir d;
    std::string text = "<scene version=\"0.5.0\">\n  <shape type=\"sphere\">\n    <float name=\"radius\" value=\"1\">\n  </shape>\n</scene>\n";
    std::string path = d.write("bad.xml", text);
    // pugixml reports the mismatched end tag, on line 4.
    expect_error(path, 4, "malformed XML");
}

TEST(SceneLoaderErrors, UnknownPlugin) {
    TempDir d;
    std::string text = scene_text("  <shape type=\"sphere\">\n    <bsdf type=\"velvet\"/>\n  </shape>\n");
    expect_error(d.write("s.xml", text), line_of(text, "velvet"), "unsupported plugin \"velvet\" (bsdf)");
    // Wrappers that nest a BSDF are named as the unsupported plugin, not reported as a misplaced <bsdf>.
    for (const char* wrapper : {"coating"}) {
        std::string w = scene_text(std::string("  <shape type=\"sphere\">\n    <bsdf type=\"") + wrapper +
                                   "\">\n      <bsdf type=\"diffuse\"/>\n    </bsdf>\n  </shape>\n");
        expect_error(d.write("w.xml", w), line_of(w, wrapper), std::string("unsupported plugin \"") + wrapper + "\" (bsdf)");
    }
    // An unsupported texture plugin names the plugin and the parameter.
    std::string tex = scene_text(
        "  <shape type=\"sphere\">\n    <bsdf type=\"diffuse\">\n"
        "      <texture type=\"wireframe\" name=\"reflectance\"/>\n"
        "    </bsdf>\n  </shape>\n");
    expect_error(d.write("t.xml", tex), line_of(tex, "wireframe"),
                 "unsupported plugin \"wireframe\" (texture for parameter \"reflectance\" of bsdf \"diffuse\"");
    // twosided mirrors a surface's front onto its back: meaningless (and refused by Mitsuba) for one that
    // transmits; an index-matched rough interface has no microfacet density.
    for (const char* glass : {"dielectric", "thindielectric", "roughdielectric"}) {
        std::string two = scene_text(std::string("  <shape type=\"sphere\">\n    <bsdf type=\"twosided\">\n      <bsdf type=\"") +
                                     glass + "\"/>\n    </bsdf>\n  </shape>\n");
        expect_error(d.write("two.xml", two), line_of(two, "twosided"), "twosided cannot wrap a BSDF that transmits light");
    }
    std::string matched = scene_text(
        "  <shape type=\"sphere\">\n    <bsdf type=\"roughdielectric\">\n"
        "      <float name=\"intIOR\" value=\"1.2\"/>\n      <float name=\"extIOR\" value=\"1.2\"/>\n    </bsdf>\n  </shape>\n");
    expect_error(d.write("m.xml", matched), line_of(matched, "roughdielectric"), "intIOR equals extIOR");
    std::string text2 = scene_text("  <shape type=\"torus\"/>\n");
    expect_error(d.write("s2.xml", text2), line_of(text2, "torus"), "unsupported shape type \"torus\"");
    std::string text3 = scene_text("  <lamp type=\"area\"/>\n");
    expect_error(d.write("s3.xml", text3), line_of(text3, "lamp"), "unknown element <lamp>");
}

TEST(SceneLoaderErrors, MisspeltParameter) {
    TempDir d;
    std::string text = scene_text(R"(  <shape type="sphere">
    <bsdf type="diffuse">
      <rgb name="reflectanse" value="0.5"/>
    </bsdf>
  </shape>
)");
    // With --strict (parse_quiet); without it a warning (SceneTolerance.MisspeltParameterKeepsTheDefault).
    expect_error(d.write("scene.xml", text), line_of(text, "reflectanse"),
                 "unknown parameter \"reflectanse\" for bsdf \"diffuse\"");
}

TEST(SceneLoaderErrors, MissingObj) {
    TempDir d;
    std::string text = scene_text(R"(  <shape type="obj">
    <string name="filename" value="meshes/nowhere.obj"/>
  </shape>
)");
    expect_error(d.write("scene.xml", text), line_of(text, "nowhere.obj"), "meshes/nowhere.obj");
}

TEST(SceneLoaderErrors, ObjWithNanVertex) {
    TempDir d;
    d.write("nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
    std::string text = scene_text(R"(  <shape type="obj">
    <string name="filename" value="nan.obj"/>
  </shape>
)");
    std::string path = d.write("scene.xml", text);
    expect_error(path, line_of(text, "nan.obj"), "non-finite");
    expect_error(path, line_of(text, "nan.obj"), "nan.obj:3:");  // and the OBJ's own line
}

TEST(SceneLoaderErrors, ObjIndexOutOfRange) {
    TempDir d;
    d.write("idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n");
    std::string text = scene_text(R"(  <shape type="obj"><string name="filename" value="idx.obj"/></shape>
)");
    std::string path = d.write("scene.xml", text);
    expect_error(path, line_of(text, "idx.obj"), "idx.obj:5:");
    expect_error(path, line_of(text, "idx.obj"), "vertex 4");
}

TEST(SceneLoaderErrors, EmptyObj) {
    TempDir d;
    d.write("empty.obj", "# nothing\nv 0 0 0\n");
    std::string text = scene_text(R"(  <shape type="obj"><string name="filename" value="empty.obj"/></shape>
)");
    expect_error(d.write("scene.xml", text), line_of(text, "empty.obj"), "no faces");
}

TEST(SceneLoaderErrors, UndefinedRef) {
    TempDir d;
    std::string text = scene_text(R"(  <shape type="sphere">
    <ref id="nosuchbsdf"/>
  </shape>
)");
    expect_error(d.write("scene.xml", text), line_of(text, "nosuchbsdf"), "undefined reference \"nosuchbsdf\"");
}

TEST(SceneLoaderErrors, BadNumber) {
    TempDir d;
    std::string text = scene_text(R"(  <shape type="sphere">
    <float name="radius" value="1.5x"/>
  </shape>
)");
    expect_error(d.write("scene.xml", text), line_of(text, "1.5x"), "bad number \"1.5x\"");
    std::string text2 = scene_text("  <shape type=\"sphere\"><point name=\"center\" x=\"1\" y=\"two\"/></shape>\n");
    expect_error(d.write("s2.xml", text2), line_of(text2, "two"), "bad number \"two\"");
}

TEST(SceneLoaderErrors, WrongValueType) {
    TempDir d;
    std::string text = scene_text(R"(  <shape type="sphere">
    <string name="radius" value="1"/>
  </shape>
)");
    expect_error(d.write("scene.xml", text), line_of(text, "radius"), "must be a <float>");
}

TEST(SceneLoaderErrors, DuplicateId) {
    TempDir d;
    std::string text = scene_text(R"(  <bsdf type="diffuse" id="x"/>
  <bsdf type="plastic" id="x"/>
)");
    expect_error(d.write("scene.xml", text), line_of(text, "plastic"), "duplicate id \"x\"");
}

TEST(SceneLoaderErrors, UnsupportedOptions) {
    TempDir d;
    std::string a = scene_text(R"(  <shape type="sphere"><bsdf type="roughconductor"><string name="distribution" value="phong"/></bsdf></shape>
)");
    expect_error(d.write("a.xml", a), line_of(a, "phong"), "unsupported");
    std::string b = scene_text("  <emitter type=\"area\"/>\n");
    expect_error(d.write("b.xml", b), line_of(b, "area"), "inside the shape");
    std::string c = scene_text("  <integrator type=\"irrcache\">\n    <integrator type=\"path\"/>\n  </integrator>\n");
    expect_error(d.write("c.xml", c), line_of(c, "\"path\""), "nested integrators");
    std::string e = scene_text("  <shape type=\"sphere\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"500:1\"/></bsdf></shape>\n");
    expect_error(d.write("e.xml", e), line_of(e, "500:1"), "at least two samples");
    std::string f = "<scene version=\"0.5.0\">\n  <shape type=\"sphere\"/>\n</scene>\n";
    expect_error(d.write("f.xml", f), 1, "no <sensor>");
}

// ---------------------------------------------------------------------------------------------------
// Full load (parse + Scene::finalize): needs the BSDF and light code.

TEST(LoaderFinalize, EverySeedSceneLoads) {
    for (const SeedCounts& c : kSeeds) {
        SCOPED_TRACE(c.file);
        std::vector<std::string> warnings;
        SceneLoadOptions opt;
        opt.warnings = &warnings;
        Scene s = load_scene(kSeed + c.file, opt);
        EXPECT_TRUE(s.accel != nullptr);
        EXPECT_EQ(s.lights.size(), c.lights);
        EXPECT_GT(s.scale(), 0.0f);
    }
}
