// PLY and Mitsuba serialized meshes, shapegroups and instances, and the tessellated analytic shapes.
//
// The PLY and serialized files are generated here from the same small polygon mesh that is also
// written as an OBJ; each must load (through the scene loader, with toWorld) to exactly the triangles,
// normals and texture coordinates of the OBJ. Instances must give the triangles of explicit copies.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "formats/ply.h"
#include "formats/scene_xml.h"
#include "formats/serialized.h"
#include "support/temp_dir.h"

using namespace iris;
namespace fs = std::filesystem;

namespace {

using iris::test::TempDir;

// A small polygon mesh: a unit-ish box with one pentagon (split top), one quad per side, irregular
// coordinates (none exactly representable in decimal), per-vertex normals and texture coordinates.
struct PolyMesh {
    std::vector<Vec3> p, n;
    std::vector<Vec2> uv;
    std::vector<std::vector<uint32_t>> faces;
};

PolyMesh test_mesh() {
    PolyMesh m;
    const float a = 0.1f, b = 1.0f / 3.0f, c = 2.7182817f;
    m.p = {{-a, -b, -c}, {c, -b, -a}, {c, b, -a}, {-a, b, -c}, {-a, -b, c}, {c, -b, c}, {c, b, c}, {-a, b, c}, {1.1f, 0.9f, c + 0.3f}};
    for (size_t i = 0; i < m.p.size(); ++i) {
        m.n.push_back(normalize(m.p[i] - Vec3(1.3f, 0.0f, 0.0f)));
        m.uv.push_back(Vec2{0.1f * float(i), 1.0f - 0.07f * float(i)});
    }
    m.faces = {{0, 3, 2, 1}, {4, 5, 8, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    return m;
}

std::string num(float v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", double(v));
    return b;
}

std::string to_obj(const PolyMesh& m, bool normals) {
    std::string s = "# test mesh\n";
    for (Vec3 p : m.p) s += "v " + num(p.x) + " " + num(p.y) + " " + num(p.z) + "\n";
    if (normals)
        for (Vec3 n : m.n) s += "vn " + num(n.x) + " " + num(n.y) + " " + num(n.z) + "\n";
    for (const auto& f : m.faces) {
        s += "f";
        for (uint32_t i : f) s += " " + std::to_string(i + 1) + (normals ? "//" + std::to_string(i + 1) : "");
        s += "\n";
    }
    return s;
}

enum class PlyFormat { Ascii, Little, Big };

template <class T>
void put(std::string* out, T v, bool big) {
    char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    if (big != (std::endian::native == std::endian::big))
        for (size_t i = 0; i < sizeof v / 2; ++i) std::swap(b[i], b[sizeof v - 1 - i]);
    out->append(b, sizeof v);
}

// Writes the mesh as PLY. uv_names: "" = no uvs, else e.g. "u v" / "s t" / "texture_u texture_v".
// Positions as doubles in the binary variants (and an unused colour property), so that the reader's
// type handling is exercised.
std::string to_ply(const PolyMesh& m, PlyFormat f, bool normals, const std::string& uv_u = "", const std::string& uv_v = "") {
    const char* fmt = f == PlyFormat::Ascii ? "ascii" : f == PlyFormat::Little ? "binary_little_endian" : "binary_big_endian";
    const bool bin = f != PlyFormat::Ascii, big = f == PlyFormat::Big;
    std::string s = std::string("ply\nformat ") + fmt + " 1.0\ncomment made by test_mesh_formats\n";
    s += "element vertex " + std::to_string(m.p.size()) + "\n";
    const char* ptype = bin ? "double" : "float";
    s += std::string("property ") + ptype + " x\nproperty " + ptype + " y\nproperty " + ptype + " z\n";
    if (normals) s += "property float nx\nproperty float ny\nproperty float nz\n";
    s += "property uchar red\n";
    if (!uv_u.empty()) s += "property float " + uv_u + "\nproperty float " + uv_v + "\n";
    s += "element face " + std::to_string(m.faces.size()) + "\nproperty list uchar int vertex_indices\n";
    s += "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
    for (size_t i = 0; i < m.p.size(); ++i) {
        if (!bin) {
            s += num(m.p[i].x) + " " + num(m.p[i].y) + " " + num(m.p[i].z);
            if (normals) s += " " + num(m.n[i].x) + " " + num(m.n[i].y) + " " + num(m.n[i].z);
            s += " 200";
            if (!uv_u.empty()) s += " " + num(m.uv[i].x) + " " + num(m.uv[i].y);
            s += "\n";
        } else {
            for (int k = 0; k < 3; ++k) put(&s, double(m.p[i][k]), big);
            if (normals)
                for (int k = 0; k < 3; ++k) put(&s, m.n[i][k], big);
            put(&s, uint8_t(200), big);
            if (!uv_u.empty()) {
                put(&s, m.uv[i].x, big);
                put(&s, m.uv[i].y, big);
            }
        }
    }
    for (const auto& face : m.faces) {
        if (!bin) {
            s += std::to_string(face.size());
            for (uint32_t i : face) s += " " + std::to_string(i);
            s += "\n";
        } else {
            put(&s, uint8_t(face.size()), big);
            for (uint32_t i : face) put(&s, int32_t(i), big);
        }
    }
    if (!bin) s += "0 1\n";
    else {
        put(&s, int32_t(0), big);
        put(&s, int32_t(1), big);
    }
    return s;
}

// The mesh triangulated as fans (what OBJ, PLY and Mitsuba all do), as a TriangleMesh.
TriangleMesh triangulated(const PolyMesh& m, bool normals, bool uvs) {
    TriangleMesh t;
    t.positions = m.p;
    if (normals) t.normals = m.n;
    if (uvs) t.uvs = m.uv;
    for (const auto& f : m.faces)
        for (size_t i = 1; i + 1 < f.size(); ++i) t.indices.insert(t.indices.end(), {f[0], f[i], f[i + 1]});
    return t;
}

const char* kToWorld =
    R"(<transform name="toWorld"><rotate x="0.3" y="1" z="0.2" angle="37"/><scale x="2" y="-1.5" z="0.7"/><translate x="3" y="-4" z="1"/></transform>)";

std::string scene_with(const std::string& shapes) {
    return std::string(R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <sensor type="perspective">
    <transform name="toWorld"><lookAt origin="0, 0, -10" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
  </sensor>
)") + shapes + "</scene>\n";
}

std::string mesh_shape(const std::string& type, const std::string& file, const std::string& extra = "") {
    return "  <shape type=\"" + type + "\"><string name=\"filename\" value=\"" + file + "\"/>" + kToWorld + extra +
           "</shape>\n";
}

Scene parse_quiet(const std::string& path, std::vector<std::string>* warnings = nullptr) {
    std::vector<std::string> local;
    SceneLoadOptions opt;
    opt.warnings = warnings ? warnings : &local;
    return parse_scene(path, opt);
}

// The world-space triangles of a mesh: corner positions, normals and uvs in index order.
struct Corners {
    std::vector<Vec3> p, n;
    std::vector<Vec2> uv;
};
Corners corners(const Mesh& m) {
    Corners c;
    for (uint32_t i : m.indices) {
        c.p.push_back(m.positions[i]);
        if (!m.normals.empty()) c.n.push_back(m.normals[i]);
        if (!m.uvs.empty()) c.uv.push_back(m.uvs[i]);
    }
    return c;
}

// Exact equality, or within `tol` (absolute) when given.
void expect_same(const Corners& a, const Corners& b, const std::string& what, float tol = 0) {
    ASSERT_EQ(a.p.size(), b.p.size()) << what;
    ASSERT_EQ(a.n.size(), b.n.size()) << what;
    for (size_t i = 0; i < a.p.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            if (tol == 0) ASSERT_EQ(a.p[i][k], b.p[i][k]) << what << " corner " << i;
            else ASSERT_NEAR(a.p[i][k], b.p[i][k], tol) << what << " corner " << i;
        }
    for (size_t i = 0; i < a.n.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            if (tol == 0) ASSERT_EQ(a.n[i][k], b.n[i][k]) << what << " normal " << i;
            else ASSERT_NEAR(a.n[i][k], b.n[i][k], tol) << what << " normal " << i;
        }
}

float triangle_area_sum(const Mesh& m) {
    double a = 0;
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        Vec3 p0 = m.positions[m.indices[t]], p1 = m.positions[m.indices[t + 1]], p2 = m.positions[m.indices[t + 2]];
        a += 0.5 * double(length(cross(p1 - p0, p2 - p0)));
    }
    return float(a);
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
TEST(MeshFormats, PlyAsciiLittleBigAndSerializedLoadTheObjTriangles) {
    const PolyMesh pm = test_mesh();
    TempDir d;
    for (bool normals : {true, false}) {
        for (bool face_normals : {false, true}) {
            const std::string extra = face_normals ? R"(<boolean name="faceNormals" value="true"/>)" : "";
            d.write("m.obj", to_obj(pm, normals));
            const Corners ref = corners(parse_quiet(d.write("obj.xml", scene_with(mesh_shape("obj", "m.obj", extra)))).meshes.at(0));
            ASSERT_EQ(ref.p.size(), 3u * (2 + 3 + 2 * 4));  // 4 quads, one pentagon
            ASSERT_EQ(ref.n.empty(), face_normals);
            const std::string label = std::string(normals ? "with" : "without") + " normals" + (face_normals ? ", faceNormals" : "");
            int k = 0;
            for (PlyFormat f : {PlyFormat::Ascii, PlyFormat::Little, PlyFormat::Big}) {
                const std::string file = "m" + std::to_string(k++) + ".ply";
                d.write(file, to_ply(pm, f, normals, "u", "v"));
                const Scene s = parse_quiet(d.write(file + ".xml", scene_with(mesh_shape("ply", file, extra))));
                ASSERT_EQ(s.meshes.size(), 1u);
                expect_same(corners(s.meshes[0]), ref, "ply " + std::to_string(k) + " " + label);
                ASSERT_EQ(s.meshes[0].uvs.size(), pm.p.size());
                EXPECT_EQ(s.meshes[0].uvs[5].x, pm.uv[5].x);
                EXPECT_EQ(s.meshes[0].uvs[5].y, pm.uv[5].y);
            }
            // Serialized: shape 1 of a two-shape file (shape 0 is a decoy), in single and double precision.
            for (bool dbl : {false, true}) {
                TriangleMesh decoy = triangulated(pm, false, false);
                decoy.positions[0] = Vec3(100.0f);
                const std::string s0 = serialize_shape(decoy, "decoy", dbl);
                const std::string s1 = serialize_shape(triangulated(pm, normals, true), "mesh", dbl);
                const std::string file = dbl ? "m_double.serialized" : "m.serialized";
                d.write(file, s0 + s1 + serialized_dictionary({s0.size(), s1.size()}));
                const Scene s = parse_quiet(
                    d.write(file + ".xml", scene_with(mesh_shape("serialized", file, extra + R"(<integer name="shapeIndex" value="1"/>)"))));
                expect_same(corners(s.meshes.at(0)), ref, std::string("serialized ") + (dbl ? "double " : "single ") + label);
                EXPECT_EQ(s.meshes[0].uvs.size(), pm.p.size());
            }
        }
    }
}

TEST(MeshFormats, PlyTextureCoordinateNamesAndTriangulation) {
    const PolyMesh pm = test_mesh();
    for (auto [u, v] : {std::pair{"s", "t"}, std::pair{"texture_u", "texture_v"}, std::pair{"texture_s", "texture_t"}}) {
        const TriangleMesh t = parse_ply(to_ply(pm, PlyFormat::Little, false, u, v), "mem.ply");
        ASSERT_EQ(t.uvs.size(), pm.p.size()) << u;
        for (size_t i = 0; i < pm.p.size(); ++i) {
            EXPECT_EQ(t.uvs[i].x, pm.uv[i].x) << u;
            EXPECT_EQ(t.uvs[i].y, pm.uv[i].y) << v;
        }
        EXPECT_EQ(t.indices, triangulated(pm, false, false).indices) << "fans (0, i, i+1)";
        EXPECT_TRUE(t.normals.empty());
    }
}

TEST(MeshFormats, SerializedRoundTripAndFlags) {
    const PolyMesh pm = test_mesh();
    TriangleMesh m = triangulated(pm, true, true);
    m.face_normals = true;
    const std::string one = serialize_shape(m, "x");
    const std::string file = one + serialized_dictionary({one.size()});
    EXPECT_EQ(serialized_shape_count(file, "f"), 1u);
    const TriangleMesh back = parse_serialized(file, 0, "f");
    EXPECT_TRUE(back.face_normals);
    EXPECT_EQ(back.indices, m.indices);
    ASSERT_EQ(back.positions.size(), m.positions.size());
    for (size_t i = 0; i < m.positions.size(); ++i) {
        for (int k = 0; k < 3; ++k) EXPECT_EQ(back.positions[i][k], m.positions[i][k]);
        for (int k = 0; k < 3; ++k) EXPECT_EQ(back.normals[i][k], m.normals[i][k]);
        EXPECT_EQ(back.uvs[i].x, m.uvs[i].x);
    }
    // The face-normal flag makes the loader shade flat, as Mitsuba does.
    TempDir d;
    d.write("f.serialized", file);
    const Scene s = parse_quiet(d.write("s.xml", scene_with(mesh_shape("serialized", "f.serialized"))));
    EXPECT_TRUE(s.meshes.at(0).normals.empty());
}

// Every way a mesh file can be broken: an error naming the mesh file, from the scene's filename line.
TEST(MeshFormats, BadFilesFailNamingTheFile) {
    const PolyMesh pm = test_mesh();
    TempDir d;
    const std::string good_le = to_ply(pm, PlyFormat::Little, true, "u", "v");
    const std::string good_ascii = to_ply(pm, PlyFormat::Ascii, true, "u", "v");
    const std::string one = serialize_shape(triangulated(pm, true, false), "x");
    const std::string ser = one + serialized_dictionary({one.size()});
    std::string flipped = ser;
    flipped[one.size() / 2] = char(flipped[one.size() / 2] ^ 0x5a);  // inside the zlib stream
    std::string bad_index = good_ascii;
    bad_index.replace(bad_index.find("4 0 3 2 1"), 9, "4 0 3 2 9");
    std::string nan_ascii = good_ascii;
    {
        const size_t at = nan_ascii.find("end_header\n") + 11;
        nan_ascii.replace(at, nan_ascii.find(' ', at) - at, "nan");
    }
    struct Case {
        const char* name;
        std::string bytes;
        const char* type;
        const char* extra;
        const char* fragment;
    };
    const Case cases[] = {
        {"trunc_le.ply", good_le.substr(0, good_le.size() - 30), "ply", "", "truncated"},
        {"trunc_header.ply", good_le.substr(0, 40), "ply", "", "end_header"},
        {"trunc_ascii.ply", good_ascii.substr(0, good_ascii.find("\n5 4 5 8")), "ply", "", "truncated"},
        {"extra.ply", good_le + "xyz", "ply", "", "do not match"},
        {"not.ply", "plx\nformat ascii 1.0\n", "ply", "", "not a PLY file"},
        {"bad_index.ply", bad_index, "ply", "", "refers to vertex 9"},
        {"nan.ply", nan_ascii, "ply", "", "non-finite x"},
        {"huge_count.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n"
                           "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
         "ply", "", "more than 2^32"},
        {"trunc.serialized", ser.substr(0, ser.size() / 2), "serialized", "", "serialized"},
        {"flipped.serialized", flipped, "serialized", "", "corrupt"},
        {"index.serialized", ser, "serialized", R"(<integer name="shapeIndex" value="3"/>)", "shapeIndex 3 is out of range"},
        {"empty.serialized", "", "serialized", "", "not a Mitsuba serialized mesh"},
    };
    for (const Case& c : cases) {
        d.write(c.name, c.bytes);
        const std::string xml = d.write(std::string(c.name) + ".xml", scene_with(mesh_shape(c.type, c.name, c.extra)));
        try {
            parse_quiet(xml);
            ADD_FAILURE() << c.name << ": no error";
        } catch (const SceneError& e) {
            const std::string msg = e.what();
            EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
            EXPECT_EQ(msg.rfind(xml + ":", 0), 0u) << msg;
            EXPECT_NE(msg.find(c.name), std::string::npos) << msg;
            EXPECT_NE(msg.find(c.fragment), std::string::npos) << c.name << ": " << msg;
        }
    }
}

// Two instances of a group (a PLY mesh with its own toWorld, a rectangle and a sphere) give the
// triangles and spheres of explicit copies with the composed transforms.
TEST(MeshFormats, InstancesEqualExplicitCopies) {
    const PolyMesh pm = test_mesh();
    TempDir d;
    d.write("m.ply", to_ply(pm, PlyFormat::Big, true, "u", "v"));
    const std::string child_ops = R"(<rotate y="1" angle="20"/><translate x="0.5"/>)";
    const std::string inst_ops[2] = {R"(<scale value="2"/><translate z="4"/>)", R"(<rotate x="1" angle="-35"/><translate y="-3"/>)"};
    std::string grouped = R"(  <shape type="shapegroup" id="g">
    <shape type="ply"><string name="filename" value="m.ply"/><transform name="toWorld">)" + child_ops + R"(</transform>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf></shape>
    <shape type="rectangle"/>
    <shape type="sphere"><float name="radius" value="0.25"/><point name="center" x="1" y="0" z="0"/></shape>
  </shape>
)";
    std::string explicit_copies;
    for (const std::string& ops : inst_ops) {
        grouped += R"(  <shape type="instance"><ref id="g"/><transform name="toWorld">)" + ops + "</transform></shape>\n";
        explicit_copies += R"(  <shape type="ply"><string name="filename" value="m.ply"/><transform name="toWorld">)" +
                           child_ops + ops + R"(</transform><bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf></shape>
  <shape type="rectangle"><transform name="toWorld">)" + ops + R"(</transform></shape>
  <shape type="sphere"><float name="radius" value="0.25"/><point name="center" x="1" y="0" z="0"/><transform name="toWorld">)" +
                           ops + "</transform></shape>\n";
    }
    const Scene a = parse_quiet(d.write("grouped.xml", scene_with(grouped)));
    const Scene b = parse_quiet(d.write("explicit.xml", scene_with(explicit_copies)));
    ASSERT_EQ(a.meshes.size(), 4u);  // the group itself adds nothing
    ASSERT_EQ(b.meshes.size(), 4u);
    ASSERT_EQ(a.spheres.size(), 2u);
    ASSERT_EQ(b.spheres.size(), 2u);
    // a: per instance, ply then rectangle; b the same order.
    for (size_t i = 0; i < 4; ++i) {
        // The child transform is applied before the instance's (positions rounded to float in
        // between), so equal to float rounding of coordinates up to ~10: 1e-5 absolute.
        expect_same(corners(a.meshes[i]), corners(b.meshes[i]), "mesh " + std::to_string(i), 1e-5f);
        EXPECT_EQ(a.meshes[i].uvs.size(), b.meshes[i].uvs.size());
        EXPECT_EQ(a.bsdfs[a.meshes[i].bsdf].diffuse.r, b.bsdfs[b.meshes[i].bsdf].diffuse.r);
    }
    for (size_t i = 0; i < 2; ++i) {
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.spheres[i].center[k], b.spheres[i].center[k], 1e-5f);
        EXPECT_NEAR(a.spheres[i].radius, b.spheres[i].radius, 1e-6f);
    }

    // Misuse: emitters inside a group, unknown group, instance of a bsdf.
    const std::string bad_cases[][2] = {
        {R"(<shape type="shapegroup" id="h"><shape type="rectangle"><emitter type="area"/></shape></shape>)", "area emitter inside a shapegroup"},
        {R"(<shape type="instance"><ref id="nope"/></shape>)", "undefined shapegroup"},
        {R"(<bsdf type="diffuse" id="bb"/><shape type="instance"><ref id="bb"/></shape>)", "not to a shapegroup"},
        {R"(<shape type="shapegroup"><shape type="rectangle"/></shape>)", "needs an id"},
    };
    for (const auto& c : bad_cases) {
        const std::string xml = d.write("bad.xml", scene_with(std::string("  ") + c[0] + "\n"));
        try {
            parse_quiet(xml);
            ADD_FAILURE() << c[0];
        } catch (const SceneError& e) {
            EXPECT_NE(std::string(e.what()).find(c[1]), std::string::npos) << e.what();
            EXPECT_EQ(std::string(e.what()).rfind(xml + ":" + std::to_string(7) + ":", 0), 0u) << e.what();
        }
    }
}

// Rectangle, disk and cube: Mitsuba's geometry (extent, facing) and area, also after a scale; an
// emitting disk gets the area light of exactly pi r^2 (light sampling and photons use that table).
TEST(MeshFormats, RectangleDiskCubeGeometryAndArea) {
    TempDir d;
    const std::string xml = d.write("a.xml", scene_with(R"(  <shape type="rectangle" id="r"><transform name="toWorld"><scale x="2" y="3"/></transform></shape>
  <shape type="disk" id="d"><transform name="toWorld"><scale value="0.5"/><translate z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
  <shape type="cube" id="c"><transform name="toWorld"><scale value="0.25"/></transform></shape>
)"));
    std::vector<std::string> warnings;
    SceneLoadOptions opt;
    opt.warnings = &warnings;
    const Scene s = load_scene(xml, opt);
    ASSERT_EQ(s.meshes.size(), 3u);
    EXPECT_NEAR(triangle_area_sum(s.meshes[0]), 2.0f * 2.0f * 2.0f * 3.0f, 1e-5f);
    ASSERT_EQ(s.meshes[0].uvs.size(), 4u);
    const Mesh& disk = s.meshes[1];
    EXPECT_EQ(disk.name, "d");
    EXPECT_NEAR(triangle_area_sum(disk), float(kPi) * 0.25f, 1e-6f);
    float rmax = 0, rmin = 1e9f;
    size_t centres = 0;  // one centre vertex per segment (its uv carries the segment's angle)
    for (size_t i = 0; i < disk.positions.size(); ++i) {
        EXPECT_EQ(disk.positions[i].z, 1.0f);
        const float r = std::hypot(disk.positions[i].x, disk.positions[i].y);
        if (r == 0) {
            ++centres;
            continue;
        }
        rmax = std::max(rmax, r);
        rmin = std::min(rmin, r);
    }
    EXPECT_EQ(centres, disk.indices.size() / 3);
    EXPECT_NEAR(rmax, 0.5f, 0.5f * 2e-5f);  // rim vertices just outside the circle, edges just inside
    EXPECT_NEAR(rmin, 0.5f, 0.5f * 2e-5f);
    for (size_t t = 0; t < disk.indices.size(); t += 3) {
        const Vec3 p0 = disk.positions[disk.indices[t]], p1 = disk.positions[disk.indices[t + 1]],
                   p2 = disk.positions[disk.indices[t + 2]];
        ASSERT_GT(cross(p1 - p0, p2 - p0).z, 0.0f) << "faces +z";
    }
    ASSERT_EQ(disk.light, 0);
    EXPECT_NEAR(s.lights[0].area, float(kPi) * 0.25f, 1e-6f);
    EXPECT_NEAR(triangle_area_sum(s.meshes[2]), 6 * 0.25f, 1e-6f);  // 6 faces of 0.5 x 0.5
}
