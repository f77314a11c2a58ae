// Stress: degenerate and zero-area triangles in OBJ meshes, on walls and on an emitter.
//
// Guards the loader and everything that divides by a triangle's area or normal length: light
// sampling (pdf = 1 / area), emitted power (selection in proportion to area), photon emission,
// geometric normals from cross products. Real meshes contain repeated vertices, collinear vertices
// and slivers whose area is not exactly zero in double but rounds to almost nothing. The scene with
// such triangles must load (exactly degenerate ones are dropped with a warning), render and trace
// photons with zero NaN/Inf samples, and give the same image as the scene without them (within 5
// combined standard errors); an emitter mesh made only of degenerate triangles is a clear error.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "formats/exr.h"
#include "formats/photon_map.h"
#include "support/image_stats.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

// The mean and standard error (support/image_stats.h), after checking no NaN/Inf sample was discarded.
ImageStats checked_stats(const Image& img, const std::string& what) {
    expect_no_nonfinite(img, what);
    return image_stats(img, what);
}

// The box's walls (inward), a light under the ceiling, a glass sphere. With `dirty`, every OBJ also
// holds degenerate triangles: repeated vertices, exactly collinear vertices, slivers (collinear in
// decimal, not quite in float), and a second emitter made only of slivers.
std::string write_scene(const TempDir& dir, const std::string& tag, bool dirty) {
    std::ofstream walls(dir.file(tag + "walls.obj"));
    // 8 corners of [-1,1]^3; faces wound to face inwards.
    walls << "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n";
    walls << "f 1 2 3\nf 1 3 4\n"   // floor z=-1, normal +z
             "f 5 8 7\nf 5 7 6\n"   // ceiling, normal -z
             "f 1 5 6\nf 1 6 2\n"   // y=-1, normal +y
             "f 4 3 7\nf 4 7 8\n"   // y=1, normal -y
             "f 1 4 8\nf 1 8 5\n"   // x=-1, normal +x
             "f 2 6 7\nf 2 7 3\n";  // x=1, normal -x
    if (dirty) {
        walls << "v 0 -1 -1\nv 0.3 0.2 0.1\nv 0.6 0.4 0.2\nv 0.9 0.6 0.3\nv 0.1 0.1 0.1\nv 0.2 0.2 0.2\nv 0.3 0.3 0.3\n";
        walls << "f 1 1 2\n"       // repeated vertex
                 "f 3 3 3\n"       // one point
                 "f 1 9 2\n"       // exactly collinear along the floor's front edge
                 "f 10 11 12\n"    // collinear in decimal, a sliver in float (inside the box)
                 "f 13 14 15\n"    // collinear in decimal and maybe in float
                 "f 2 9 1\n";      // the same, reversed
    }
    walls.close();
    std::ofstream light(dir.file(tag + "light.obj"));
    light << "v -0.25 -0.25 0.98\nv 0.25 -0.25 0.98\nv 0.25 0.25 0.98\nv -0.25 0.25 0.98\n";
    light << "f 1 3 2\nf 1 4 3\n";  // facing down
    if (dirty) {
        light << "v 0 -0.25 0.98\nv 0.1 0.1 0.98\nv 0.2 0.2 0.98\nv 0.30000001 0.3 0.98\n";
        light << "f 1 1 3\n"      // repeated vertex
                 "f 1 5 2\n"      // exactly collinear on the light's edge
                 "f 6 7 8\n"      // sliver on the light's plane
                 "f 4 4 4\n";
    }
    light.close();
    std::string extra;
    if (dirty) {
        // An emitter whose only triangles are slivers: area ~1e-14, its light is never worth choosing.
        std::ofstream sl(dir.file(tag + "sliver_light.obj"));
        sl << "v -0.5 0.5 0.5\nv -0.4 0.6 0.6\nv -0.3 0.70000001 0.7\nv -0.2 0.8 0.8\n";
        sl << "f 1 2 3\nf 2 3 4\nf 1 3 4\n";
        sl.close();
        extra = "<shape type=\"obj\"><string name=\"filename\" value=\"" + tag +
                "sliver_light.obj\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"50, 50, 50\"/></emitter></shape>\n";
    }
    const std::string path = dir.file(tag + "scene.xml");
    std::ofstream(path) << "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
                           "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"8\"/></integrator>\n"
                           "<shape type=\"obj\"><string name=\"filename\" value=\"" + tag + "walls.obj\"/>"
                           "<boolean name=\"faceNormals\" value=\"true\"/>"
                           "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6, 0.5, 0.4\"/></bsdf></shape>\n"
                           "<shape type=\"obj\"><string name=\"filename\" value=\"" + tag + "light.obj\"/>"
                           "<emitter type=\"area\"><rgb name=\"radiance\" value=\"12, 10, 8\"/></emitter></shape>\n"
                        + extra +
                           "<shape type=\"sphere\"><point name=\"center\" x=\"0.3\" y=\"0.2\" z=\"-0.6\"/>"
                           "<float name=\"radius\" value=\"0.35\"/><bsdf type=\"dielectric\"/></shape>\n"
                           "<sensor type=\"perspective\"><float name=\"fov\" value=\"75\"/>"
                           "<transform name=\"toWorld\"><lookAt origin=\"0, -0.9, 0.2\" target=\"0, 0.3, -0.3\" up=\"0, 0, 1\"/></transform>"
                           "<sampler type=\"independent\"><integer name=\"sampleCount\" value=\"16\"/></sampler>"
                           "<film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/><integer name=\"height\" value=\"24\"/>"
                           "<rfilter type=\"box\"/></film></sensor>\n</scene>\n";
    return path;
}

}  // namespace

TEST(DegenerateGeometry, RendersLikeTheCleanScene) {
    TempDir dir;
    const std::string clean = write_scene(dir, "clean_", false), dirty = write_scene(dir, "dirty_", true);
    ToolResult r = run_command(tool("render") + " " + clean + " -o " + dir.file("c.exr") + " --variance -q -t 2 --spp 128 --seed 1");
    ASSERT_EQ(r.status, 0) << r.output;
    r = run_command(tool("render") + " " + dirty + " -o " + dir.file("d.exr") + " --variance -q -t 2 --spp 128 --seed 2");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("degenerate"), std::string::npos) << "the loader reports what it dropped: " << r.output;
    const ImageStats a = checked_stats(read_exr(dir.file("c.exr")), "clean"), b = checked_stats(read_exr(dir.file("d.exr")), "dirty");
    ASSERT_GT(a.mean[0], 0.05);
    for (int c = 0; c < 3; ++c) {
        const double se = std::hypot(a.se[c], b.se[c]);
        EXPECT_NEAR(b.mean[c], a.mean[c], 5 * se) << "channel " << "RGB"[c] << ", standard error " << se;
    }
}

TEST(DegenerateGeometry, PhotonTracingAndGuidedRenderStayFinite) {
    TempDir dir;
    const std::string scene = write_scene(dir, "dirty_", true);
    const std::string ph = dir.file("p.h5"), ca = dir.file("c.h5"), at = dir.file("a.h5");
    ToolResult r = run_command(tool("trace-photons") + " " + scene + " --set photon-paths=20000 --seed 3 -q -t 2 -o " + ph);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(r.output.find("NaN"), std::string::npos) << r.output;
    const PhotonMapFile pf = read_photon_map(ph);
    EXPECT_EQ(pf.header.provenance.parameters.at("nonfinite_discarded"), 0.0);
    ASSERT_GT(pf.photons.size(), 10000u);
    for (size_t i = 0; i < pf.photons.size(); ++i) {
        ASSERT_TRUE(is_finite(pf.photons.position[i]) && is_finite(pf.photons.normal[i]));
        const RGB& p = pf.photons.power[i];
        ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && p[0] >= 0);
    }
    r = run_command(tool("place-caches") + " " + scene + " --photon-map " + ph + " -o " + ca + " --set cache-count=200 --set camera-stride=4 -q -t 2");
    ASSERT_EQ(r.status, 0) << r.output;
    r = run_command(tool("fill-caches") + " " + ca + " --photon-map " + ph + " -o " + at + " --set gather-count=100 --set map-resolution=8 -q -t 2");
    ASSERT_EQ(r.status, 0) << r.output;
    r = run_command(tool("render") + " " + scene + " --set pilot=off --atlas " + at + " -o " + dir.file("g.exr") + " --variance -q -t 2 --spp 16");
    ASSERT_EQ(r.status, 0) << r.output;
    checked_stats(read_exr(dir.file("g.exr")), "guided");
}

// An emitter mesh with no triangle of non-zero area: a one-line error naming the mesh, no image.
TEST(DegenerateGeometry, EmitterWithOnlyDegenerateTrianglesIsAClearError) {
    TempDir dir;
    std::ofstream(dir.file("bad.obj")) << "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n";
    std::ofstream(dir.file("bad.xml")) << "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
                                          "<shape type=\"obj\"><string name=\"filename\" value=\"bad.obj\"/>"
                                          "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter></shape>\n"
                                          "<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/>"
                                          "<integer name=\"height\" value=\"4\"/></film></sensor>\n</scene>\n";
    const std::string out = dir.file("x.exr");
    ToolResult r = run_command(tool("render") + " " + dir.file("bad.xml") + " -q -o " + out);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("render: error:"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("non-zero area"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("bad"), std::string::npos) << r.output;
    EXPECT_FALSE(std::ifstream(out).good());
}
