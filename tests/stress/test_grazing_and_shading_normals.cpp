// Stress: grazing rays and shading normals far from the geometric normal.
//
// Guards the BSDFs and the integrator where cosines go to zero and frames disagree: a camera looking
// along a floor (every ray at 89.9+ degrees from its normal, and a camera lying in the floor's plane)
// over diffuse, rough conductor (Beckmann and GGX, nearly smooth and rough) and rough plastic floors,
// where masking functions, Fresnel terms and 1/cos factors turn into 0/0 or inf; and an OBJ whose
// vertex normals are tilted by up to 89 degrees, some below the surface, one zero. Output must be
// finite with zero NaN/Inf samples. The furnace check: a closed box that emits Le and reflects
// diffusely with albedo rho has radiance Le / (1 - rho) everywhere with true normals; with shading
// normals each bounce can only lose energy (the cosine-weighted integral of a tilted lobe over the
// true hemisphere is at most pi), so the image mean must lie between Le (the emission seen
// directly) and Le / (1 - rho), up to noise -- shading normals must never create energy.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "formats/exr.h"
#include "libcommon/rng.h"
#include "support/image_stats.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

// Renders `scene` with --variance; its mean and standard error, after the no-NaN/Inf checks.
ImageStats render_stats(const std::string& scene, const std::string& args, const TempDir& dir, const std::string& what) {
    const std::string out = dir.file("out.exr");
    ToolResult r = run_command(tool("render") + " " + scene + " -o " + out + " --variance -q -t 2 " + args);
    EXPECT_EQ(r.status, 0) << what << ": " << r.output;
    if (r.status != 0) return {};
    const Image img = read_exr(out);
    expect_no_nonfinite(img, what);
    return image_stats(img, what);
}

}  // namespace

// A floor of each BSDF seen at 89.9+ degrees, from just above it and from inside its plane.
TEST(GrazingRays, CameraAlongAFloorGivesFiniteImages) {
    TempDir dir;
    const std::string floors[] = {
        R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf>)",
        R"(<bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.0001"/></bsdf>)",
        R"(<bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/><float name="alpha" value="0.5"/></bsdf>)",
        R"(<bsdf type="roughconductor"><string name="material" value="Al"/><string name="distribution" value="beckmann"/><float name="alpha" value="0.05"/></bsdf>)",
        R"(<bsdf type="roughplastic"><float name="alpha" value="0.02"/><rgb name="diffuseReflectance" value="0.5, 0.3, 0.2"/></bsdf>)",
        R"(<bsdf type="conductor"><string name="material" value="Ag"/></bsdf>)",
    };
    // Camera heights above the floor (z = -0.9): 1e-4 (rays within 0.1 degree of the plane hit it ~0.06
    // away) and 0 (the camera in the plane: half the rays start on the floor going down).
    const char* heights[] = {"-0.8999", "-0.9"};
    int k = 0;
    for (const std::string& floor : floors)
        for (const char* z : heights) {
            const std::string path = dir.file("g" + std::to_string(k++) + ".xml");
            std::ofstream(path) << R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="6"/></integrator>
  <shape type="cube"><boolean name="flipNormals" value="true"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.99" y="0.99"/><translate z="-0.9"/></transform>
    )" + floor + R"(
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.3" y="0.3"/><rotate x="1" angle="180"/><translate y="0.5" z="0.95"/></transform>
    <emitter type="area"><rgb name="radiance" value="20, 20, 20"/></emitter>
  </shape>
  <sensor type="perspective">
    <float name="fov" value="0.2"/><float name="nearClip" value="1e-5"/>
    <transform name="toWorld"><lookAt origin="0, -0.95, )" + z + R"(" target="0, 1, )" + z + R"(" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="12"/><rfilter type="gaussian"/></film>
  </sensor>
</scene>
)";
            render_stats(path, "--spp 32 --seed 1", dir, floor + " at z " + z);
        }
}

namespace {

// The box [-1,1]^3 as an OBJ with inward faces, each face split into a 3x3 grid of quads with its
// own vertices, so every vertex normal can be perturbed independently. `tilt`: largest tilt of a
// vertex normal off the inward normal, degrees; every fourth normal points below the surface
// (tilted 100..170 degrees) and one is zero. tilt < 0: the true normals.
void write_box_obj(const std::string& path, double tilt, uint64_t seed) {
    std::ofstream f(path);
    Rng rng = Rng::for_index(seed, Stream::Test, 0);
    int v = 0, vn = 0;
    const int G = 3;
    for (int axis = 0; axis < 3; ++axis)
        for (int side : {-1, 1}) {
            const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
            double n_in[3] = {0, 0, 0};
            n_in[axis] = -side;  // inwards
            const int base = v;
            for (int j = 0; j <= G; ++j)
                for (int i = 0; i <= G; ++i) {
                    double p[3];
                    p[axis] = side;
                    p[a1] = -1 + 2.0 * i / G;
                    p[a2] = -1 + 2.0 * j / G;
                    f << "v " << p[0] << " " << p[1] << " " << p[2] << "\n";
                    ++v;
                    // The normal: n_in tilted by theta towards a random tangent direction.
                    double theta = tilt < 0 ? 0 : tilt * M_PI / 180 * rng.next_double();
                    if (tilt >= 0 && vn % 4 == 3) theta = (100 + 70 * rng.next_double()) * M_PI / 180;
                    const double phi = 2 * M_PI * rng.next_double();
                    double n[3];
                    n[axis] = n_in[axis] * std::cos(theta);
                    n[a1] = std::sin(theta) * std::cos(phi);
                    n[a2] = std::sin(theta) * std::sin(phi);
                    if (tilt >= 0 && vn == 17) n[0] = n[1] = n[2] = 0;  // a zero normal
                    f << "vn " << n[0] << " " << n[1] << " " << n[2] << "\n";
                    ++vn;
                }
            for (int j = 0; j < G; ++j)
                for (int i = 0; i < G; ++i) {
                    const int q[4] = {base + j * (G + 1) + i + 1, base + j * (G + 1) + i + 2,
                                      base + (j + 1) * (G + 1) + i + 2, base + (j + 1) * (G + 1) + i + 1};
                    // Listed as is, the quad's normal is e_a1 x e_a2 = +axis: inwards on the side -1.
                    const bool ccw_is_inward = (side < 0);
                    auto corner = [&](int c) { return std::to_string(q[c]) + "//" + std::to_string(q[c]); };
                    if (ccw_is_inward)
                        f << "f " << corner(0) << " " << corner(1) << " " << corner(2) << " " << corner(3) << "\n";
                    else
                        f << "f " << corner(0) << " " << corner(3) << " " << corner(2) << " " << corner(1) << "\n";
                }
        }
}

std::string furnace_scene(const TempDir& dir, const std::string& tag, double tilt) {
    write_box_obj(dir.file(tag + ".obj"), tilt, 7);
    const std::string path = dir.file(tag + ".xml");
    std::ofstream(path) << R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"/>
  <shape type="obj"><string name="filename" value=")" + tag + R"(.obj"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
  <sensor type="perspective">
    <float name="fov" value="100"/>
    <transform name="toWorld"><lookAt origin="0.2, -0.3, 0.1" target="1, 0.4, -0.6" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
</scene>
)";
    return path;
}

}  // namespace

// With true normals: exactly Le / (1 - rho) = 2 (the OBJ's winding is right and the test can see the
// answer). With normals tilted up to 60 and 89 degrees, some below the surface and one zero: finite,
// no NaN/Inf sample, and between Le = 1 and 2.
TEST(ShadingNormals, PerturbedNormalsNeverCreateEnergyInAFurnace) {
    TempDir dir;
    const ImageStats truth = render_stats(furnace_scene(dir, "true", -1), "--spp 64 --seed 2", dir, "true normals");
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(truth.mean[c], 2.0, 5 * truth.se[c] + 1e-4) << "true normals";
    for (double tilt : {60.0, 89.0}) {
        const std::string what = "tilt " + std::to_string(int(tilt));
        const ImageStats s = render_stats(furnace_scene(dir, "tilt" + std::to_string(int(tilt)), tilt), "--spp 64 --seed 3",
                                     dir, what);
        for (int c = 0; c < 3; ++c) {
            EXPECT_LE(s.mean[c], 2.0 * (1 + 1e-4) + 5 * s.se[c]) << what << ": shading normals created energy";
            EXPECT_GE(s.mean[c], 1.0 - 5 * s.se[c]) << what;
        }
    }
}

// The same perturbed box through photon tracing: photon powers finite (the adjoint shading-normal
// correction divides by |cos| against the true normal).
TEST(ShadingNormals, PhotonsFromPerturbedNormalsAreFinite) {
    TempDir dir;
    const std::string scene = furnace_scene(dir, "tilt89", 89);
    const std::string ph = dir.file("p.h5"), ca = dir.file("c.h5"), at = dir.file("a.h5");
    ToolResult r = run_command(tool("trace-photons") + " " + scene + " --set photon-paths=5000 -q -t 2 -o " + ph);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(r.output.find("NaN"), std::string::npos) << r.output;
    r = run_command(tool("place-caches") + " " + scene + " --photon-map " + ph + " -o " + ca + " --set cache-count=100 --set camera-stride=4 -q -t 2");
    ASSERT_EQ(r.status, 0) << r.output;
    r = run_command(tool("fill-caches") + " " + ca + " --photon-map " + ph + " -o " + at + " --set gather-count=64 --set map-resolution=8 -q -t 2");
    ASSERT_EQ(r.status, 0) << r.output;
    render_stats(scene, "--spp 16 --set pilot=off --atlas " + at, dir, "guided, tilt 89");
}
