// The bad-input catalogue: every way a user can hand a tool something wrong -- a malformed or
// truncated scene, an unknown plugin, a missing or corrupt mesh, a stage file of the wrong kind, made
// for another scene, truncated or no HDF5 at all, a nonsense flag, an unwritable output -- and the
// contract each must meet (DESIGN.md section 3): a non-zero exit that is not a crash, exactly one line
// of output "TOOL: error: ..." naming the problem (the flag, or the file at fault), and nothing written:
// no output file and no temporary file.
//
// One test per case. With IRIS_ROBUSTNESS_TABLE=FILE set, each case also appends a Markdown table row
// with the message the tool printed; scripts/robustness-table.sh turns that into docs/ROBUSTNESS.md.
#include <gtest/gtest.h>

#include <cstring>
#include <hdf5.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "formats/serialized.h"
#include "support/run_tool.h"

namespace fs = std::filesystem;
using namespace iris::test;

namespace {

struct BadInputCase {
    const char* id;       // test name
    const char* tool;     // which executable
    const char* problem;  // what is wrong, for the catalogue in docs/ROBUSTNESS.md
    const char* args;     // {in}/NAME: a prepared input file; {out}: the output path (in an empty folder)
    const char* mention;  // the error line must contain this (the flag, the file's name, or the reason)
    // Where `mention` is only a file's name: the reason the line must give too (what is wrong with the file),
    // so that any other error naming the file cannot pass.
    const char* reason = nullptr;
};

// A mention that is only a path (it names a file, no reason): such a case needs `reason`.
bool names_only_a_file(const std::string& m) {
    static const char* const kExtensions[] = {".xml", ".h5", ".obj", ".exr", ".png", ".hdr", ".ply", ".serialized", ".jpg"};
    if (m.find(' ') != std::string::npos) return false;
    for (const char* e : kExtensions)
        if (m.size() >= std::strlen(e) && m.compare(m.size() - std::strlen(e), std::string::npos, e) == 0) return true;
    return false;
}

// Scene files: a small valid scene with one defect each. The base is a sphere lit by a rectangle.
std::string scene_with(const std::string& shape_body, const std::string& extra = "") {
    return R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"/>
  <shape type="rectangle">
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
  <shape )" + shape_body + R"(
  </shape>)" + extra + R"(
  <sensor type="perspective">
    <transform name="toWorld"><lookAt origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
</scene>
)";
}

std::string obj_shape(const std::string& file) {
    return "type=\"obj\">\n    <string name=\"filename\" value=\"" + file + "\"/>";
}

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

std::string read_bytes(const fs::path& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
        if (!line.empty()) out.push_back(line);
    return out;
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
    return s;
}

// (Names the case in gtest's messages instead of dumping its bytes.)
void PrintTo(const BadInputCase& c, std::ostream* os) { *os << c.id; }

class BadInput : public ::testing::TestWithParam<BadInputCase> {
protected:
    // Inputs shared by all cases: valid stage files of the caustic test scene and of the furnace box
    // (another scene), a valid image, and one defective file per kind of defect. ctest runs every case
    // in its own process, so they are made once per build of the tools, in the build tree: into a
    // staging folder renamed into place when complete (a concurrent case that loses the race uses the
    // winner's).
    static void SetUpTestSuite() {
        // FNV-1a over the modification times of the tools and of this test binary (whose make_inputs
        // may have changed).
        uint64_t stamp = 1469598103934665603ull;
        for (const char* t : {"trace-photons", "place-caches", "fill-caches", "render", "compare-images", "inspect-caches",
                              "merge-images", "merge-photons"}) {
            const auto ticks = uint64_t(fs::last_write_time(tool(t)).time_since_epoch().count());
            stamp = (stamp ^ ticks) * 1099511628211ull;
        }
        stamp = (stamp ^ uint64_t(fs::last_write_time("/proc/self/exe").time_since_epoch().count())) * 1099511628211ull;
        const fs::path root = fs::path(IRIS_BIN_DIR).parent_path() / "test-inputs";
        dir_ = root / ("bad-input-" + std::to_string(stamp));
        if (fs::exists(dir_ / "complete")) return;
        fs::create_directories(root);
        char tmpl[4096];
        std::snprintf(tmpl, sizeof tmpl, "%s/staging-XXXXXX", root.c_str());
        const fs::path staging = ::mkdtemp(tmpl);
        make_inputs(staging);
        write_text(staging / "complete", "");
        std::error_code ec;
        fs::rename(staging, dir_, ec);
        if (ec) fs::remove_all(staging);  // another process made them first
        ASSERT_TRUE(fs::exists(dir_ / "complete"));
        // Inputs made for earlier builds of the tools are of no further use.
        for (const auto& e : fs::directory_iterator(root, ec))
            if (e.path() != dir_ && e.path().filename().string().rfind("bad-input-", 0) == 0) fs::remove_all(e.path(), ec);
    }
    static void make_inputs(const fs::path& dir) {
        auto in = [&](const std::string& name) { return (dir / name).string(); };
        auto run = [](const std::string& cmd) {
            ToolResult r = run_command(cmd);
            ASSERT_EQ(r.status, 0) << cmd << "\n" << r.output;
        };
        const std::string caustic = data_file("guiding/caustic_box.xml"), furnace = data_file("render/furnace_box.xml");
        const std::string q = " -q --seed 3";
        run(tool("trace-photons") + " " + caustic + " -o " + in("photons.h5") + " --set photon-paths=2000" + q);
        run(tool("place-caches") + " " + caustic + " --photon-map " + in("photons.h5") + " -o " + in("caches.h5") +
            " --set cache-count=40" + q);
        run(tool("fill-caches") + " " + in("caches.h5") + " --photon-map " + in("photons.h5") + " -o " + in("atlas.h5") +
            " --set gather-count=50 --set map-resolution=4" + q);
        run(tool("trace-photons") + " " + furnace + " -o " + in("furnace_photons.h5") + " --set photon-paths=500" + q);
        run(tool("place-caches") + " " + furnace + " --photon-map " + in("furnace_photons.h5") + " -o " +
            in("furnace_caches.h5") + " --set cache-count=10" + q);
        run(tool("fill-caches") + " " + in("furnace_caches.h5") + " --photon-map " + in("furnace_photons.h5") + " -o " +
            in("furnace_atlas.h5") + " --set gather-count=20 --set map-resolution=4" + q);
        run(tool("render") + " " + furnace + " -o " + in("image.exr") + " --spp 4" + q);
        run(tool("render") + " " + furnace + " -o " + in("small.exr") + " --spp 4 --resolution 8x8" + q);
        // Parts of a render (render --sample-range) and of a photon map (trace-photons --path-range).
        const std::string part = tool("render") + " " + furnace + " --spp 4 --resolution 8x8" + q;
        run(part + " --sample-range 0:2 -o " + in("part_a.exr"));
        run(part + " --sample-range 2:4 -o " + in("part_b.exr"));
        run(part + " --sample-range 1:3 -o " + in("part_overlap.exr"));
        run(part + " --sample-range 2:4 --set max-depth=3 -o " + in("part_depth.exr"));
        run(tool("render") + " " + caustic + " --spp 4 --resolution 8x8 --sample-range 2:4 -o " + in("part_other_scene.exr") + q);
        const std::string ppart = tool("trace-photons") + " " + caustic + " --set photon-paths=2000" + q;
        run(ppart + " --path-range 0:1000 -o " + in("photons_a.h5"));
        run(ppart + " --path-range 1000:2000 -o " + in("photons_b.h5"));
        run(ppart + " --path-range 500:1500 -o " + in("photons_overlap.h5"));
        run(ppart + " --path-range 1000:2000 --set photon-depth=3 -o " + in("photons_depth.h5"));
        run(tool("trace-photons") + " " + furnace + " --set photon-paths=2000 --path-range 1000:2000 -o " + in("photons_other_scene.h5") + q);

        // Files that are not what they claim to be.
        write_text(in("text.h5"), "not an HDF5 file\n");
        write_text(in("empty.h5"), "");
        write_text(in("text.exr"), "not an image\n");
        for (const char* name : {"photons.h5", "caches.h5", "atlas.h5", "image.exr", "part_b.exr", "photons_b.h5"}) {
            const std::string bytes = read_bytes(in(name));
            write_text(in(std::string("truncated_") + name), bytes.substr(0, bytes.size() / 2));
        }
        {  // A valid atlas but for its resolution, larger than any the renderer packs.
            fs::copy_file(in("atlas.h5"), in("resolution512_atlas.h5"));
            hid_t f = H5Fopen(in("resolution512_atlas.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
            ASSERT_GE(f, 0);
            hid_t a = H5Aopen(f, "resolution", H5P_DEFAULT);
            ASSERT_GE(a, 0);
            const int32_t r = 512;
            ASSERT_GE(H5Awrite(a, H5T_NATIVE_INT32, &r), 0);
            H5Aclose(a);
            H5Fclose(f);
        }
        {  // A valid HDF5 file that is no iris stage file.
            hid_t f = H5Fcreate(in("plain.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
            ASSERT_GE(f, 0);
            H5Fclose(f);
        }

        // Scenes.
        const std::string sphere = "type=\"sphere\">\n    <float name=\"radius\" value=\"0.5\"/>";
        write_text(in("valid.xml"), scene_with(sphere));
        write_text(in("malformed.xml"), "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n  <shape type=\"sphere\">\n");
        const std::string caustic_text = read_bytes(caustic);
        write_text(in("caustic.xml"), caustic_text);  // (so that every scene argument reads {in}/NAME)
        write_text(in("truncated.xml"), caustic_text.substr(0, caustic_text.size() * 6 / 10));
        write_text(in("unknown_plugin.xml"), scene_with(sphere + "\n    <bsdf type=\"velvet\"/>"));
        write_text(in("bumpmap.xml"), scene_with(sphere + "\n    <bsdf type=\"bumpmap\"><bsdf type=\"diffuse\"/></bsdf>"));
        write_text(in("mask.xml"), scene_with(sphere + "\n    <bsdf type=\"mask\"><spectrum name=\"opacity\" value=\"0.4\"/></bsdf>"));
        write_text(in("mask_colour.xml"), scene_with(sphere + "\n    <bsdf type=\"mask\"><rgb name=\"opacity\" value=\"0.2, 0.5, 0.5\"/>"
                                                              "<bsdf type=\"diffuse\"/></bsdf>"));
        write_text(in("mask_emitter.xml"), scene_with(sphere + "\n    <bsdf type=\"mask\"><bsdf type=\"diffuse\"/></bsdf>"
                                                               "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter>"));
        // mixturebsdf / blendbsdf / phong (formats/mitsuba/bsdfs.cpp): what Mitsuba 0.5 rejects, and phong's
        // negative exponent (Mitsuba takes it and computes garbage).
        auto mixture = [&](const std::string& weights, int n) {
            std::string body = "\n    <bsdf type=\"mixturebsdf\"><string name=\"weights\" value=\"" + weights + "\"/>";
            for (int i = 0; i < n; ++i) body += "<bsdf type=\"diffuse\"/>";
            return scene_with(sphere + body + "</bsdf>");
        };
        write_text(in("mixture_count.xml"), mixture("0.5, 0.5", 3));
        write_text(in("mixture_negative.xml"), mixture("0.5, -0.5", 2));
        write_text(in("mixture_word.xml"), mixture("0.5, half", 2));
        write_text(in("mixture_zero.xml"), mixture("0, 0", 2));
        write_text(in("mixture_no_weights.xml"), scene_with(sphere + "\n    <bsdf type=\"mixturebsdf\"><bsdf type=\"diffuse\"/></bsdf>"));
        write_text(in("blend_one.xml"), scene_with(sphere + "\n    <bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.3\"/>"
                                                            "<bsdf type=\"diffuse\"/></bsdf>"));
        write_text(in("phong_exponent.xml"), scene_with(sphere + "\n    <bsdf type=\"phong\"><float name=\"exponent\" value=\"-2\"/></bsdf>"));
        auto textured = [&](const std::string& file) {
            return scene_with(sphere + "\n    <bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
                                       "<string name=\"filename\" value=\"" + file + "\"/></texture></bsdf>");
        };
        write_text(in("texture.xml"), textured("wood.png"));  // wood.png does not exist
        write_text(in("not_a_png.png"), "this is no PNG image\n");
        write_text(in("texture_garbage.xml"), textured("not_a_png.png"));
        write_text(in("texture_zero.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n");
        write_text(in("texture_zero_hdr.xml"), textured("texture_zero.hdr"));
        write_text(in("texture_unsupported.xml"),
                   scene_with(sphere + "\n    <bsdf type=\"diffuse\"><texture type=\"wireframe\" name=\"reflectance\"/></bsdf>"));
        write_text(in("misspelt.xml"), scene_with("type=\"sphere\">\n    <float name=\"radus\" value=\"0.5\"/>"));
        write_text(in("blackbody_negative.xml"),
                   scene_with(sphere + "\n    <bsdf type=\"diffuse\"><blackbody name=\"reflectance\" temperature=\"-300\"/></bsdf>"));
        const std::string integrator = "<integrator type=\"path\"/>";
        write_text(in("medium_interior.xml"),
                   replace_all(scene_with(sphere + "\n    <ref name=\"interior\" id=\"milk\"/>"), integrator,
                               integrator + "\n  <medium type=\"homogeneous\" id=\"milk\"/>"));
        write_text(in("ref_unsupported.xml"),
                   replace_all(scene_with(sphere + "\n    <ref id=\"cloth\"/>"), integrator,
                               integrator + "\n  <bsdf type=\"velvet\" id=\"cloth\"/>"));
        write_text(in("bad_number.xml"), scene_with("type=\"sphere\">\n    <float name=\"radius\" value=\"half\"/>"));
        write_text(in("nan_number.xml"), scene_with("type=\"sphere\">\n    <float name=\"radius\" value=\"nan\"/>"));
        write_text(in("negative_radius.xml"), scene_with("type=\"sphere\">\n    <float name=\"radius\" value=\"-1\"/>"));
        write_text(in("huge_sphere.xml"),
                   scene_with(sphere + "\n    <transform name=\"toWorld\"><scale value=\"1e38\"/></transform>"));
        write_text(in("bad_rgb.xml"),
                   scene_with(sphere + "\n    <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5, 0.5\"/></bsdf>"));
        write_text(in("wrong_version.xml"),
                   replace_all(scene_with(sphere), "<scene version=\"0.5.0\">", "<scene version=\"3.0.0\">"));
        write_text(in("unset_parameter.xml"), scene_with("type=\"sphere\">\n    <float name=\"radius\" value=\"$r\"/>"));
        write_text(in("missing_mesh.xml"), scene_with(obj_shape("no_such_mesh.obj")));
        write_text(in("bad_index.xml"), scene_with(obj_shape("bad_index.obj")));
        write_text(in("bad_index.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
        write_text(in("garbage_obj.xml"), scene_with(obj_shape("garbage.obj")));
        write_text(in("garbage.obj"), "v 1 zwei 3\n\x01\x02\xff\n");
        write_text(in("nan_vertex.xml"), scene_with(obj_shape("nan_vertex.obj")));
        write_text(in("nan_vertex.obj"), "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
        write_text(in("huge_vertex.xml"), scene_with(obj_shape("huge_vertex.obj")));
        write_text(in("huge_vertex.obj"), "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
        write_text(in("empty_obj.xml"), scene_with(obj_shape("empty.obj")));
        // Emitters: envmaps missing, unreadable or with nonsense parameters; spot and directional lights
        // with impossible angles or no direction.
        auto emitter = [&](const std::string& body) { return scene_with(sphere, "\n  <emitter " + body + "</emitter>"); };
        write_text(in("envmap_missing.xml"), emitter(R"(type="envmap"><string name="filename" value="no_such_sky.exr"/>)"));
        write_text(in("not_an_exr.exr"), "this is no OpenEXR image\n");
        write_text(in("envmap_garbage.xml"), emitter(R"(type="envmap"><string name="filename" value="not_an_exr.exr"/>)"));
        write_text(in("envmap_empty_file.exr"), "");
        write_text(in("envmap_zero.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n");
        write_text(in("envmap_zero_hdr.xml"), emitter(R"(type="envmap"><string name="filename" value="envmap_zero.hdr"/>)"));
        write_text(in("envmap_empty.xml"), emitter(R"(type="envmap"><string name="filename" value="envmap_empty_file.exr"/>)"));
        write_text(in("envmap_negative_scale.xml"),
                   emitter(R"(type="envmap"><string name="filename" value="image.exr"/><float name="scale" value="-2"/>)"));
        write_text(in("spot_cutoff.xml"), emitter(R"(type="spot"><float name="cutoffAngle" value="-5"/>)"));
        write_text(in("spot_beam.xml"),
                   emitter(R"(type="spot"><float name="cutoffAngle" value="10"/><float name="beamWidth" value="30"/>)"));
        write_text(in("directional_zero.xml"), emitter(R"(type="directional"><vector name="direction" x="0" y="0" z="0"/>)"));
        // Daylight: a turbidity outside the sky model's 1..10, a month 13, a sun below the horizon (2 am
        // in Tokyo), a sun direction given beside a place.
        write_text(in("sunsky_turbidity0.xml"), emitter(R"(type="sunsky"><float name="turbidity" value="0"/>)"));
        write_text(in("sky_turbidity20.xml"), emitter(R"(type="sky"><float name="turbidity" value="20"/>)"));
        write_text(in("sunsky_month13.xml"), emitter(R"(type="sunsky"><integer name="month" value="13"/>)"));
        write_text(in("sunsky_night.xml"), emitter(R"(type="sunsky"><float name="hour" value="2"/>)"));
        write_text(in("sunsky_direction_and_place.xml"),
                   emitter(R"(type="sunsky"><vector name="sunDirection" x="0" y="1" z="0"/><float name="latitude" value="48"/>)"));
        write_text(in("empty.obj"), "# no faces\nv 0 0 0\n");
        // PLY and Mitsuba serialized meshes: a valid triangle, then broken copies.
        auto mesh_shape = [](const char* type, const std::string& file, const std::string& extra = "") {
            return std::string("type=\"") + type + "\">\n    <string name=\"filename\" value=\"" + file + "\"/>" + extra;
        };
        std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        const int32_t tri[3] = {0, 1, 2};
        ply.append(reinterpret_cast<const char*>(xyz), sizeof xyz).push_back('\3');
        ply.append(reinterpret_cast<const char*>(tri), sizeof tri);
        write_text(in("truncated_ply.xml"), scene_with(mesh_shape("ply", "truncated.ply")));
        write_text(in("truncated.ply"), ply.substr(0, ply.size() - 7));
        write_text(in("corrupt_ply.xml"), scene_with(mesh_shape("ply", "corrupt.ply")));
        write_text(in("corrupt.ply"), replace_all(ply, "property float y", "property flaot y"));
        iris::TriangleMesh m;
        m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        m.indices = {0, 1, 2};
        const std::string shape = iris::serialize_shape(m, "triangle");
        const std::string ser = shape + iris::serialized_dictionary({shape.size()});
        write_text(in("truncated_serialized.xml"), scene_with(mesh_shape("serialized", "truncated.serialized")));
        write_text(in("truncated.serialized"), ser.substr(0, ser.size() / 2));
        std::string corrupt = ser;
        for (size_t i = 6; i < shape.size() - 4; ++i) corrupt[i] = char(corrupt[i] ^ 0xa5);  // the zlib stream
        write_text(in("corrupt_serialized.xml"), scene_with(mesh_shape("serialized", "corrupt.serialized")));
        write_text(in("corrupt.serialized"), corrupt);
        write_text(in("shape_index.xml"),
                   scene_with(mesh_shape("serialized", "good.serialized", "\n    <integer name=\"shapeIndex\" value=\"2\"/>")));
        write_text(in("good.serialized"), ser);
        std::string version7 = ser;
        version7[2] = 7;  // the shape's uint16 version field (Mitsuba writes 3 or 4)
        write_text(in("serialized_version.xml"), scene_with(mesh_shape("serialized", "version7.serialized")));
        write_text(in("version7.serialized"), version7);
        fs::create_directory(in("adir"));
    }
    static fs::path dir_;
};
fs::path BadInput::dir_;

TEST_P(BadInput, OneLineErrorNoOutput) {
    const BadInputCase& c = GetParam();
    TempDir out_dir;
    const std::string tool_name = c.tool;
    const std::string ext = tool_name == "render" || tool_name == "inspect-caches" || tool_name == "merge-images" ? ".exr"
                            : tool_name == "compare-images"                      ? ".png"
                                                                                 : ".h5";
    const std::string out = out_dir.file("out" + ext);
    std::string args = replace_all(replace_all(c.args, "{in}", dir_.string()), "{out}", out);
    const bool has_quiet = tool_name != "compare-images" && tool_name != "inspect-caches";
    const std::string cmd = tool(tool_name) + " " + args + (has_quiet ? " -q" : "");
    const auto inputs_before = std::distance(fs::directory_iterator(dir_), fs::directory_iterator());
    ToolResult r = run_command(cmd);
    SCOPED_TRACE(cmd);

    EXPECT_TRUE(r.status > 0 && r.status < 128) << "expected an error exit, got status " << r.status << "\n" << r.output;
    const std::vector<std::string> lines = lines_of(r.output);
    ASSERT_EQ(lines.size(), 1u) << "expected exactly one line of output, got:\n" << r.output;
    const std::string& line = lines[0];
    EXPECT_EQ(line.rfind(tool_name + ": error: ", 0), 0u) << line;
    EXPECT_NE(line.find(c.mention), std::string::npos) << "the error should mention \"" << c.mention << "\": " << line;
    if (c.reason) {
        EXPECT_NE(line.find(c.reason), std::string::npos) << "the error should say \"" << c.reason << "\": " << line;
    }
    EXPECT_TRUE(c.reason || !names_only_a_file(c.mention)) << c.id << ": a case that names only the file needs the reason";
    EXPECT_LE(line.size(), 400u) << "an error line should be short enough to read";
    // Nothing written: the output folder stays empty (no output, no temporary file), and no input folder
    // gains a file either (an output path pointing there).
    EXPECT_TRUE(fs::is_empty(out_dir.path)) << "a file was left in the output folder";
    EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), inputs_before)
        << "a file appeared among the inputs";

    if (const char* table = std::getenv("IRIS_ROBUSTNESS_TABLE")) {
        // Paths of this run's temporary folders become in/ and out/ so the table reads the same every time.
        std::string shown = replace_all(replace_all(line, dir_.string() + "/", "in/"), out_dir.path.string() + "/", "out/");
        shown = replace_all(shown, std::string(IRIS_SOURCE_DIR) + "/", "");
        shown = replace_all(shown, "|", "\\|");
        std::ofstream(table, std::ios::app) << "| `" << c.tool << "` | " << c.problem << " | `" << shown << "` |\n";
    }
}

// clang-format off
const BadInputCase kCases[] = {
    // ---- Scene files (read by every tool that takes a scene; shown through render) ----
    {"SceneMissing", "render", "scene file does not exist", "{in}/missing.xml -o {out}", "missing.xml", "cannot read the scene file"},
    {"SceneNotXml", "render", "scene file is not XML", "{in}/text.h5 -o {out}", "text.h5", "malformed XML"},
    {"SceneMalformed", "render", "malformed XML (unclosed element)", "{in}/malformed.xml -o {out}", "malformed.xml", "malformed XML: Start-end tags mismatch"},
    {"SceneTruncated", "render", "scene file cut off midway", "{in}/truncated.xml -o {out}", "truncated.xml", "malformed XML"},
    {"SceneUnknownPlugin", "render", "unknown plugin (bsdf type velvet)", "{in}/unknown_plugin.xml -o {out}", "velvet"},
    {"SceneBumpmap", "render", "bumpmap without its displacement texture", "{in}/bumpmap.xml -o {out}", "bumpmap needs a displacement <texture>"},
    {"SceneMaskWithoutBsdf", "render", "mask without its nested BSDF", "{in}/mask.xml -o {out}", "mask needs a nested <bsdf> or <ref>"},
    {"SceneMaskColoured", "render", "mask with a coloured opacity", "{in}/mask_colour.xml -o {out}", "a coloured opacity is not supported"},
    {"SceneMaskEmitter", "render", "area emitter on a masked shape", "{in}/mask_emitter.xml -o {out}", "an area emitter on a shape whose bsdf is a mask"},
    {"TracePhotonsMaskWithoutBsdf", "trace-photons", "mask without its nested BSDF", "{in}/mask.xml -o {out}", "mask needs a nested <bsdf> or <ref>"},
    {"SceneMixtureWeightCount", "render", "mixturebsdf with 2 weights for 3 BSDFs", "{in}/mixture_count.xml -o {out}", "2 weights for 3 nested BSDFs"},
    {"SceneMixtureNegativeWeight", "render", "mixturebsdf with a negative weight", "{in}/mixture_negative.xml -o {out}", "weight \"-0.5\" is negative"},
    {"SceneMixtureWeightWord", "render", "mixturebsdf weight that is not a number", "{in}/mixture_word.xml -o {out}", "weight \"half\" is not a number"},
    {"SceneMixtureZeroWeights", "render", "mixturebsdf weights summing to 0", "{in}/mixture_zero.xml -o {out}", "weights must sum to more than 0"},
    {"SceneMixtureNoWeights", "render", "mixturebsdf without weights", "{in}/mixture_no_weights.xml -o {out}", "mixturebsdf needs weights"},
    {"SceneBlendOneBsdf", "render", "blendbsdf with one nested BSDF", "{in}/blend_one.xml -o {out}", "blendbsdf needs exactly two nested BSDFs"},
    {"ScenePhongNegativeExponent", "render", "phong with a negative exponent", "{in}/phong_exponent.xml -o {out}", "exponent must be finite and non-negative"},
    {"SceneTextureUnsupported", "render", "unsupported texture plugin (wireframe)", "{in}/texture_unsupported.xml -o {out}", "unsupported plugin \"wireframe\""},
    {"TextureMissing", "render", "bitmap texture file does not exist", "{in}/texture.xml -o {out}", "wood.png", "cannot read texture file"},
    {"TextureGarbage", "render", "bitmap texture file that is not an image", "{in}/texture_garbage.xml -o {out}", "not_a_png.png", "unrecognised image format"},
    {"TextureHdrZeroSize", "render", "Radiance HDR texture of 0 x 0 pixels", "{in}/texture_zero_hdr.xml -o {out}", "texture_zero.hdr", "HDR image has an unsupported size"},
    {"TracePhotonsTextureMissing", "trace-photons", "bitmap texture file does not exist", "{in}/texture.xml -o {out}", "wood.png", "cannot read texture file"},
    {"SceneMisspeltParameter", "render", "--strict: misspelt parameter (radus; without --strict a warning)", "{in}/misspelt.xml --strict -o {out}", "radus", "unknown parameter"},
    {"TracePhotonsStrictUnread", "trace-photons", "--strict: a parameter its plugin does not read", "{in}/misspelt.xml --strict -o {out}", "misspelt.xml", "unknown parameter \"radus\""},
    {"SceneBlackbodyNegative", "render", "blackbody spectrum with a negative temperature", "{in}/blackbody_negative.xml -o {out}", "blackbody_negative.xml", "temperature must be positive"},
    {"SceneMediumInterior", "render", "a medium as a shape's interior (media are not built)", "{in}/medium_interior.xml -o {out}", "medium \"milk\"", "participating media are not supported yet"},
    {"SceneRefUnsupported", "render", "a shape refers to a top-level plugin iris does not build (velvet)", "{in}/ref_unsupported.xml -o {out}", "ref_unsupported.xml", "refers to unsupported plugin \"velvet\""},
    {"RenderSpectrumInterpolationWord", "render", "spectrum-interpolation neither linear nor mitsuba-0.5.0", "{in}/valid.xml --set spectrum-interpolation=cubic -o {out}", "spectrum-interpolation"},
    {"SceneBadNumber", "render", "a number that is not one", "{in}/bad_number.xml -o {out}", "bad_number.xml", "bad number \"half\" for parameter \"radius\""},
    {"SceneNanNumber", "render", "NaN as a parameter value", "{in}/nan_number.xml -o {out}", "nan_number.xml", "bad number \"nan\""},
    {"SceneNegativeRadius", "render", "negative sphere radius", "{in}/negative_radius.xml -o {out}", "radius"},
    {"SceneSphereOverflows", "render", "sphere scaled past float range (radius 0.5 x 1e38)", "{in}/huge_sphere.xml -o {out}", "not finite"},
    {"SceneBadRgb", "render", "rgb value with two components", "{in}/bad_rgb.xml -o {out}", "bad_rgb.xml", "an <rgb> value is one or three numbers"},
    {"SceneWrongVersion", "render", "scene format version iris does not read", "{in}/wrong_version.xml -o {out}", "version"},
    {"SceneUnsetParameter", "render", "$r used but neither defined nor defaulted", "{in}/unset_parameter.xml -o {out}", "$r"},
    {"SceneBadDefine", "render", "-D without name=value", "{in}/valid.xml -D radius -o {out}", "-D"},
    {"MeshMissing", "render", "OBJ mesh file does not exist", "{in}/missing_mesh.xml -o {out}", "no_such_mesh.obj", "cannot read mesh file"},
    {"MeshBadIndex", "render", "OBJ face index out of range", "{in}/bad_index.xml -o {out}", "bad_index.obj", "face refers to vertex 9 but the file has 3"},
    {"MeshGarbage", "render", "OBJ with garbage text and binary bytes", "{in}/garbage_obj.xml -o {out}", "garbage.obj", "bad number \"zwei\" in vertex"},
    {"MeshNanVertex", "render", "OBJ vertex with NaN coordinate", "{in}/nan_vertex.xml -o {out}", "nan_vertex.obj", "vertex has a non-finite coordinate"},
    {"MeshInfVertex", "render", "OBJ vertex overflowing float (1e39)", "{in}/huge_vertex.xml -o {out}", "huge_vertex.obj", "bad number \"1e39\" in vertex"},
    {"MeshEmpty", "render", "OBJ without faces", "{in}/empty_obj.xml -o {out}", "empty.obj", "has no faces"},
    {"EnvmapMissing", "render", "envmap file does not exist", "{in}/envmap_missing.xml -o {out}", "no_such_sky.exr", "cannot read envmap file"},
    {"EnvmapGarbage", "render", "envmap file that is not an image", "{in}/envmap_garbage.xml -o {out}", "not_an_exr.exr", "unrecognised image format"},
    {"EnvmapEmptyFile", "render", "envmap file of 0 bytes", "{in}/envmap_empty.xml -o {out}", "envmap_empty_file.exr", "empty image file"},
    {"EnvmapHdrZeroSize", "render", "Radiance HDR envmap of 0 x 0 pixels", "{in}/envmap_zero_hdr.xml -o {out}", "envmap_zero.hdr", "HDR image has an unsupported size"},
    {"EnvmapNegativeScale", "render", "envmap scale -2", "{in}/envmap_negative_scale.xml -o {out}", "scale"},
    {"SpotNegativeCutoff", "render", "spot light cutoffAngle -5", "{in}/spot_cutoff.xml -o {out}", "cutoffAngle"},
    {"SpotBeamWiderThanCutoff", "render", "spot light beamWidth 30 > cutoffAngle 10", "{in}/spot_beam.xml -o {out}", "beamWidth"},
    {"DirectionalZeroDirection", "render", "directional light with direction (0, 0, 0)", "{in}/directional_zero.xml -o {out}", "direction"},
    {"SunskyTurbidityZero", "render", "sunsky turbidity 0 (the sky model covers 1 to 10)", "{in}/sunsky_turbidity0.xml -o {out}", "turbidity 0 is outside [1, 10]"},
    {"SkyTurbidityTwenty", "render", "sky turbidity 20", "{in}/sky_turbidity20.xml -o {out}", "turbidity 20 is outside [1, 10]"},
    {"SunskyMonthThirteen", "render", "sunsky month 13", "{in}/sunsky_month13.xml -o {out}", "month 13 is outside [1, 12]"},
    {"SunskySunBelowHorizon", "render", "sunsky at 2 am: the sun below the horizon", "{in}/sunsky_night.xml -o {out}", "the sun is below the horizon"},
    {"SunskyDirectionAndPlace", "render", "sunsky with both sunDirection and latitude", "{in}/sunsky_direction_and_place.xml -o {out}", "give either sunDirection or the date, time and place"},
    {"TracePhotonsSunskyMonthThirteen", "trace-photons", "sunsky month 13", "{in}/sunsky_month13.xml -o {out}", "month 13 is outside [1, 12]"},
    {"TracePhotonsEnvmapMissing", "trace-photons", "envmap file does not exist", "{in}/envmap_missing.xml -o {out}", "no_such_sky.exr", "cannot read envmap file"},
    {"PlyTruncated", "render", "binary PLY cut short in its face list", "{in}/truncated_ply.xml -o {out}", "truncated.ply", "truncated?"},
    {"PlyCorrupt", "render", "PLY header with an unknown property type", "{in}/corrupt_ply.xml -o {out}", "corrupt.ply", "unknown property type \"flaot\""},
    {"SerializedTruncated", "render", "serialized mesh cut in half", "{in}/truncated_serialized.xml -o {out}", "truncated.serialized", "corrupt or truncated serialized mesh"},
    {"SerializedCorrupt", "render", "serialized mesh with scrambled zlib data", "{in}/corrupt_serialized.xml -o {out}", "corrupt.serialized", "corrupt compressed data"},
    {"SerializedBadVersion", "render", "serialized mesh of version 7 (Mitsuba writes 3 and 4)", "{in}/serialized_version.xml -o {out}", "version7.serialized", "unsupported serialized mesh version 7"},
    {"SerializedBadShapeIndex", "render", "shapeIndex 2 in a one-shape serialized file", "{in}/shape_index.xml -o {out}", "shapeIndex"},
    {"TracePhotonsSceneMissing", "trace-photons", "scene file does not exist", "{in}/missing.xml -o {out}", "missing.xml", "cannot read the scene file"},
    {"PlaceCachesSceneMalformed", "place-caches", "malformed scene", "{in}/malformed.xml --photon-map {in}/photons.h5 -o {out}", "malformed.xml", "malformed XML"},

    // ---- render flags and inputs ----
    {"RenderNegativeSpp", "render", "--spp -1", "{in}/valid.xml --spp -1 -o {out}", "--spp"},
    {"RenderTextSpp", "render", "--spp abc", "{in}/valid.xml --spp abc -o {out}", "--spp"},
    {"RenderZeroResolution", "render", "--resolution 0x5", "{in}/valid.xml --resolution 0x5 -o {out}", "--resolution"},
    {"RenderTextResolution", "render", "--resolution abc", "{in}/valid.xml --resolution abc -o {out}", "--resolution"},
    {"RenderNegativeTime", "render", "--time -3", "{in}/valid.xml --time -3 -o {out}", "--time"},
    {"RenderNegativeThreads", "render", "--threads -1", "{in}/valid.xml -t -1 -o {out}", "--threads"},
    {"RenderNegativeSnapshot", "render", "--snapshot -1", "{in}/valid.xml --snapshot -1 -o {out}", "--snapshot"},
    {"RenderBsdfFraction", "render", "--set bsdf-fraction=1.5", "{in}/valid.xml --atlas {in}/atlas.h5 --set bsdf-fraction=1.5 -o {out}", "bsdf-fraction"},
    {"RenderBsdfFractionWord", "render", "bsdf-fraction neither auto nor a number", "{in}/valid.xml --atlas {in}/atlas.h5 --set bsdf-fraction=half -o {out}", "bsdf-fraction"},
    {"RenderMinGainBelowOne", "render", "--set min-gain=0.5", "{in}/valid.xml --atlas {in}/atlas.h5 --set min-gain=0.5 -o {out}", "min-gain"},
    {"RenderRrThresholdZero", "render", "--set rr-threshold=0", "{in}/valid.xml --set rr-threshold=0 -o {out}", "rr-threshold"},
    {"RenderRrThresholdAboveOne", "render", "--set rr-threshold=2", "{in}/valid.xml --set rr-threshold=2 -o {out}", "rr-threshold"},
    {"RenderRrDepthZero", "render", "--set rr-depth=0", "{in}/valid.xml --set rr-depth=0 -o {out}", "rr-depth"},
    {"RenderNegativeGuideVertices", "render", "--set guide-vertices=-1", "{in}/valid.xml --atlas {in}/atlas.h5 --set guide-vertices=-1 -o {out}", "guide-vertices"},
    {"RenderUnknownMode", "render", "mode that does not exist", "{in}/valid.xml --set mode=bogus -o {out}", "bogus"},
    {"RenderUnknownCaustics", "render", "caustics that does not exist", "{in}/valid.xml --set caustics=sometimes -o {out}", "sometimes"},
    {"RenderUnknownProduct", "render", "product that is neither on nor off", "{in}/valid.xml --set product=maybe -o {out}", "maybe"},
    {"RenderUnknownConnect", "render", "connect that does not exist", "{in}/valid.xml --set connect=sometimes -o {out}", "sometimes"},
    {"RenderUnknownSampler", "render", "sampler that does not exist", "{in}/valid.xml --set sampler=halton -o {out}", "halton"},
    {"RenderLightPathsZero", "render", "--set light-paths=0", "{in}/valid.xml --set caustics=on --set light-paths=0 -o {out}", "light-paths"},
    {"RenderCacheModeWithoutAtlas", "render", "mode=nee+cache without --atlas", "{in}/valid.xml --set mode=nee+cache -o {out}", "--atlas"},
    {"RenderSampleRangeWithTime", "render", "--sample-range with --time", "{in}/valid.xml --time 1 --sample-range 0:2 -o {out}", "--time"},
    {"RenderSampleRangeAuto", "render", "--sample-range with the pilot (the default with --atlas)", "{in}/caustic.xml --atlas {in}/atlas.h5 --spp 4 --sample-range 0:2 -o {out}", "pilot=off"},
    {"RenderSampleRangeBeyondSpp", "render", "--sample-range beyond --spp", "{in}/valid.xml --spp 4 --sample-range 2:8 -o {out}", "2:8"},
    {"RenderSampleRangeReversed", "render", "--sample-range 5:2", "{in}/valid.xml --spp 8 --sample-range 5:2 -o {out}", "--sample-range"},
    {"RenderSampleRangeSnapshot", "render", "--sample-range with --snapshot", "{in}/valid.xml --spp 4 --sample-range 0:2 --snapshot 5 -o {out}", "--snapshot"},
    {"RenderSampleRangeLearn", "render", "--sample-range with --set learn=on (maps refit from earlier samples)", "{in}/caustic.xml --atlas {in}/atlas.h5 --set learn=on --set pilot=off --spp 4 --sample-range 0:2 -o {out}", "learn=on"},
    {"RenderUnknownFlag", "render", "a flag that does not exist", "{in}/valid.xml --no-such-flag -o {out}", "--no-such-flag"},
    {"RenderNoOutput", "render", "-o left out", "{in}/valid.xml", "--output"},
    {"RenderAtlasMissing", "render", "--atlas file does not exist", "{in}/valid.xml --atlas {in}/missing.h5 -o {out}", "missing.h5", "No such file or directory"},
    {"RenderAtlasNotHdf5", "render", "--atlas is a text file", "{in}/valid.xml --atlas {in}/text.h5 -o {out}", "not an HDF5 file"},
    {"RenderAtlasEmpty", "render", "--atlas is an empty file", "{in}/valid.xml --atlas {in}/empty.h5 -o {out}", "empty.h5", "not an HDF5 file"},
    {"RenderAtlasTruncated", "render", "--atlas cut off midway", "{in}/valid.xml --atlas {in}/truncated_atlas.h5 -o {out}", "truncated_atlas.h5", "damaged or truncated HDF5 file"},
    {"RenderAtlasWrongKind", "render", "--atlas is a photon map", "{in}/valid.xml --atlas {in}/photons.h5 -o {out}", "iris-photon-map"},
    {"RenderAtlasPlainHdf5", "render", "--atlas is an HDF5 file but no stage file", "{in}/valid.xml --atlas {in}/plain.h5 -o {out}", "plain.h5", "not an iris stage file"},
    {"RenderAtlasResolutionTooLarge", "render", "--atlas of 512 x 512 maps (the renderer packs at most 256)", "{in}/caustic.xml --atlas {in}/resolution512_atlas.h5 -o {out}", "resolution512_atlas.h5: attribute 'resolution' is 512 (must be 1..256)"},
    {"RenderAtlasOtherScene", "render", "--atlas made for another scene", "{in}/valid.xml --atlas {in}/furnace_atlas.h5 -o {out}", "another scene"},
    {"RenderOutputDirMissing", "render", "output folder does not exist", "{in}/valid.xml -o /nonexistent-dir/x.exr", "/nonexistent-dir/x.exr", "output directory does not exist"},
    {"RenderOutputIsDirectory", "render", "output path is a folder", "{in}/valid.xml -o {in}/adir", "directory"},

    // ---- trace-photons ----
    {"TracePhotonsCausticShareAboveOne", "trace-photons", "--set min-caustic-share=2", "{in}/valid.xml --set min-caustic-share=2 -o {out}", "min-caustic-share"},
    {"TracePhotonsNegativePaths", "trace-photons", "--set photon-paths=-5 (once wrapped to 2^64-5)", "{in}/valid.xml --set photon-paths=-5 -o {out}", "photon-paths"},
    {"TracePhotonsTextPaths", "trace-photons", "--set photon-paths=abc", "{in}/valid.xml --set photon-paths=abc -o {out}", "photon-paths"},
    {"TracePhotonsZeroPhotons", "trace-photons", "--set photon-count=0", "{in}/valid.xml --set photon-count=0 -o {out}", "photon-count"},
    {"TracePhotonsPhotonsWithPathRange", "trace-photons", "photon-count with --path-range", "{in}/caustic.xml --set photon-count=1000 --path-range 0:10 -o {out}", "--path-range needs the setting photon-paths"},
    {"TracePhotonsPathRangeBeyond", "trace-photons", "--path-range beyond photon-paths", "{in}/caustic.xml --set photon-paths=100 --path-range 50:200 -o {out}", "--path-range 50:200"},
    {"TracePhotonsPathRangeReversed", "trace-photons", "--path-range 5:2", "{in}/caustic.xml --set photon-paths=100 --path-range 5:2 -o {out}", "--path-range"},
    {"TracePhotonsZeroDepth", "trace-photons", "--set photon-depth=0", "{in}/valid.xml --set photon-depth=0 -o {out}", "photon-depth"},
    {"TracePhotonsNegativeDepth", "trace-photons", "--set photon-depth=-3", "{in}/valid.xml --set photon-depth=-3 -o {out}", "photon-depth"},
    {"TracePhotonsZeroRrDepth", "trace-photons", "--set photon-rr-depth=0", "{in}/valid.xml --set photon-rr-depth=0 -o {out}", "photon-rr-depth"},
    {"TracePhotonsCutoff", "trace-photons", "--set photon-cutoff=1", "{in}/valid.xml --set photon-cutoff=1 -o {out}", "photon-cutoff"},
    {"TracePhotonsNegativeThreads", "trace-photons", "--threads -1", "{in}/valid.xml -t -1 -o {out}", "--threads"},
    {"TracePhotonsUnknownFlag", "trace-photons", "a flag that does not exist", "{in}/valid.xml --no-such-flag 3 -o {out}", "--no-such-flag"},
    {"TracePhotonsOutputDirMissing", "trace-photons", "output folder does not exist", "{in}/valid.xml -o /nonexistent-dir/x.h5", "/nonexistent-dir/x.h5", "output directory does not exist"},
    {"TracePhotonsOutputIsDirectory", "trace-photons", "output path is a folder", "{in}/valid.xml -o {in}/adir", "directory"},

    // ---- place-caches ----
    {"PlaceCachesZeroCount", "place-caches", "--set cache-count=0", "{in}/valid.xml --photon-map {in}/photons.h5 --set cache-count=0 -o {out}", "cache-count"},
    {"PlaceCachesNegativeCount", "place-caches", "--set cache-count=-3", "{in}/valid.xml --photon-map {in}/photons.h5 --set cache-count=-3 -o {out}", "cache-count"},
    {"PlaceCachesNegativeStride", "place-caches", "--set camera-stride=-1", "{in}/valid.xml --photon-map {in}/photons.h5 --set camera-stride=-1 -o {out}", "camera-stride"},
    {"PlaceCachesCausticShareAboveOne", "place-caches", "--set min-caustic-share=2", "{in}/valid.xml --photon-map {in}/photons.h5 --set min-caustic-share=2 -o {out}", "min-caustic-share"},
    {"PlaceCachesZeroResolution", "place-caches", "--resolution 0x4", "{in}/valid.xml --photon-map {in}/photons.h5 --resolution 0x4 -o {out}", "--resolution"},
    {"PlaceCachesNegativeThreads", "place-caches", "--threads -1", "{in}/valid.xml --photon-map {in}/photons.h5 -t -1 -o {out}", "--threads"},
    {"PlaceCachesNoPhotons", "place-caches", "--photon-map left out", "{in}/valid.xml -o {out}", "--photon-map"},
    {"PlaceCachesPhotonsMissing", "place-caches", "photon map does not exist", "{in}/valid.xml --photon-map {in}/missing.h5 -o {out}", "missing.h5", "No such file or directory"},
    {"PlaceCachesPhotonsOtherScene", "place-caches", "photon map made for another scene", "{in}/valid.xml --photon-map {in}/photons.h5 -o {out}", "another scene"},
    {"PlaceCachesPhotonsAreAtlas", "place-caches", "an atlas given as the photon map", "{in}/valid.xml --photon-map {in}/atlas.h5 -o {out}", "iris-cache-atlas"},
    {"PlaceCachesPhotonsAreCaches", "place-caches", "cache points given as the photon map", "{in}/valid.xml --photon-map {in}/caches.h5 -o {out}", "iris-cache-points"},
    {"PlaceCachesPhotonsNotHdf5", "place-caches", "photon map is a text file", "{in}/valid.xml --photon-map {in}/text.h5 -o {out}", "not an HDF5 file"},
    {"PlaceCachesPhotonsTruncated", "place-caches", "photon map cut off midway", "{in}/valid.xml --photon-map {in}/truncated_photons.h5 -o {out}", "truncated_photons.h5", "damaged or truncated HDF5 file"},
    {"PlaceCachesOutputIsDirectory", "place-caches", "output path is a folder", "{in}/caustic.xml --photon-map {in}/photons.h5 -o {in}/adir", "directory"},
    {"PlaceCachesOutputDirMissing", "place-caches", "output folder does not exist", "{in}/valid.xml --photon-map {in}/photons.h5 -o /nonexistent-dir/x.h5", "/nonexistent-dir/x.h5", "output directory does not exist"},

    // ---- fill-caches ----
    {"FillCachesZeroK", "fill-caches", "--set gather-count=0", "{in}/caches.h5 --photon-map {in}/photons.h5 --set gather-count=0 -o {out}", "gather-count"},
    {"FillCachesNegativeK", "fill-caches", "--set gather-count=-2", "{in}/caches.h5 --photon-map {in}/photons.h5 --set gather-count=-2 -o {out}", "gather-count"},
    {"FillCachesZeroResolution", "fill-caches", "--set map-resolution=0", "{in}/caches.h5 --photon-map {in}/photons.h5 --set map-resolution=0 -o {out}", "map-resolution"},
    {"FillCachesHugeResolution", "fill-caches", "--set map-resolution=257", "{in}/caches.h5 --photon-map {in}/photons.h5 --set map-resolution=257 -o {out}", "map-resolution"},
    {"FillCachesZeroFloor", "fill-caches", "--set floor=0", "{in}/caches.h5 --photon-map {in}/photons.h5 --set floor=0 -o {out}", "floor"},
    {"FillCachesFloorAboveOne", "fill-caches", "--set floor=1.5", "{in}/caches.h5 --photon-map {in}/photons.h5 --set floor=1.5 -o {out}", "floor"},
    {"FillCachesZeroRadius", "fill-caches", "--set max-radius=0", "{in}/caches.h5 --photon-map {in}/photons.h5 --set max-radius=0 -o {out}", "max-radius"},
    {"FillCachesNegativeSigma", "fill-caches", "--set filter-sigma=-1", "{in}/caches.h5 --photon-map {in}/photons.h5 --set filter-sigma=-1 -o {out}", "filter-sigma"},
    {"FillCachesNegativeThreads", "fill-caches", "--threads -1", "{in}/caches.h5 --photon-map {in}/photons.h5 -t -1 -o {out}", "--threads"},
    {"FillCachesCachesMissing", "fill-caches", "cache file does not exist", "{in}/missing.h5 --photon-map {in}/photons.h5 -o {out}", "missing.h5", "No such file or directory"},
    {"FillCachesPhotonsMissing", "fill-caches", "photon map does not exist", "{in}/caches.h5 --photon-map {in}/missing.h5 -o {out}", "missing.h5", "No such file or directory"},
    {"FillCachesMismatchedScenes", "fill-caches", "caches and photons of different scenes", "{in}/caches.h5 --photon-map {in}/furnace_photons.h5 -o {out}", "another scene"},
    {"FillCachesPhotonsAreAtlas", "fill-caches", "an atlas given as the photon map", "{in}/caches.h5 --photon-map {in}/atlas.h5 -o {out}", "iris-cache-atlas"},
    {"FillCachesCachesArePhotons", "fill-caches", "a photon map given as the caches", "{in}/photons.h5 --photon-map {in}/photons.h5 -o {out}", "iris-photon-map"},
    {"FillCachesCachesNotHdf5", "fill-caches", "cache file is a text file", "{in}/text.h5 --photon-map {in}/photons.h5 -o {out}", "not an HDF5 file"},
    {"FillCachesCachesEmpty", "fill-caches", "cache file is empty", "{in}/empty.h5 --photon-map {in}/photons.h5 -o {out}", "empty.h5", "not an HDF5 file"},
    {"FillCachesCachesTruncated", "fill-caches", "cache file cut off midway", "{in}/truncated_caches.h5 --photon-map {in}/photons.h5 -o {out}", "truncated_caches.h5", "damaged or truncated HDF5 file"},
    {"FillCachesPhotonsTruncated", "fill-caches", "photon map cut off midway", "{in}/caches.h5 --photon-map {in}/truncated_photons.h5 -o {out}", "truncated_photons.h5", "damaged or truncated HDF5 file"},
    {"FillCachesCachesPlainHdf5", "fill-caches", "HDF5 file that is no stage file", "{in}/plain.h5 --photon-map {in}/photons.h5 -o {out}", "plain.h5", "not an iris stage file"},
    {"FillCachesOutputDirMissing", "fill-caches", "output folder does not exist", "{in}/caches.h5 --photon-map {in}/photons.h5 -o /nonexistent-dir/x.h5", "/nonexistent-dir/x.h5", "output directory does not exist"},
    {"FillCachesOutputIsDirectory", "fill-caches", "output path is a folder", "{in}/caches.h5 --photon-map {in}/photons.h5 -o {in}/adir", "directory"},

    // ---- inspect-caches ----
    {"InspectMissing", "inspect-caches", "stage file does not exist", "{in}/missing.h5", "missing.h5", "No such file or directory"},
    {"InspectNotHdf5", "inspect-caches", "stage file is a text file", "{in}/text.h5", "not an HDF5 file"},
    {"InspectPlainHdf5", "inspect-caches", "HDF5 file that is no stage file", "{in}/plain.h5", "plain.h5", "not an iris stage file"},
    {"InspectTruncated", "inspect-caches", "atlas cut off midway", "{in}/truncated_atlas.h5", "truncated_atlas.h5", "damaged or truncated HDF5 file"},
    {"InspectCacheOutOfRange", "inspect-caches", "--cache beyond the atlas", "{in}/atlas.h5 --cache 999999 -o {out}", "999999"},
    {"InspectCacheOfPhotons", "inspect-caches", "--cache on a photon map", "{in}/photons.h5 --cache 0", "atlas"},
    {"InspectPixelWithoutScene", "inspect-caches", "--pixel without --scene", "{in}/atlas.h5 --pixel 3,4", "--scene"},
    {"InspectPixelOtherScene", "inspect-caches", "--scene other than the atlas's", "{in}/atlas.h5 --scene {in}/valid.xml --pixel 3,4", "another scene"},
    {"InspectPixelOutside", "inspect-caches", "--pixel outside the image", "{in}/atlas.h5 --scene {in}/caustic.xml --pixel 999,4", "outside"},
    {"InspectOutputWithoutCache", "inspect-caches", "-o without --cache or --pixel", "{in}/atlas.h5 -o {out}", "--cache"},
    {"InspectBadLayout", "inspect-caches", "--layout that does not exist", "{in}/atlas.h5 --cache 0 --layout polar -o {out}", "--layout"},

    // ---- merge-images ----
    {"MergeImagesOverlap", "merge-images", "parts whose sample ranges overlap (0:2, 1:3)", "{in}/part_a.exr {in}/part_overlap.exr -o {out}", "overlap: both hold samples 1:2"},
    {"MergeImagesMissingRange", "merge-images", "a part missing (0:2 of 4 spp given)", "{in}/part_a.exr -o {out}", "samples 2:4 missing"},
    {"MergeImagesOtherScene", "merge-images", "parts of different scenes", "{in}/part_a.exr {in}/part_other_scene.exr -o {out}", "another scene"},
    {"MergeImagesOtherSettings", "merge-images", "parts with different max-depth", "{in}/part_a.exr {in}/part_depth.exr -o {out}", "max-depth=3"},
    {"MergeImagesNotAPart", "merge-images", "a whole render given as a part", "{in}/part_a.exr {in}/image.exr -o {out}", "image.exr: not a part"},
    {"MergeImagesTruncated", "merge-images", "a part cut off midway", "{in}/part_a.exr {in}/truncated_part_b.exr -o {out}", "truncated_part_b.exr", "Early end of file"},
    {"MergeImagesSamePartTwice", "merge-images", "one part given twice", "{in}/part_a.exr {in}/part_a.exr {in}/part_b.exr -o {out}", "overlap"},
    {"MergeImagesOutputDirMissing", "merge-images", "output folder does not exist", "{in}/part_a.exr {in}/part_b.exr -o /nonexistent-dir/x.exr", "/nonexistent-dir/x.exr", "output directory does not exist"},

    // ---- merge-photons ----
    {"MergePhotonsOverlap", "merge-photons", "parts whose path ranges overlap (0:1000, 500:1500)", "{in}/photons_a.h5 {in}/photons_overlap.h5 -o {out}", "overlap: both hold paths 500:1000"},
    {"MergePhotonsMissingRange", "merge-photons", "a part missing (1000:2000 of 2000 paths)", "{in}/photons_b.h5 -o {out}", "paths 0:1000 missing"},
    {"MergePhotonsOtherScene", "merge-photons", "parts of different scenes", "{in}/photons_a.h5 {in}/photons_other_scene.h5 -o {out}", "another scene"},
    {"MergePhotonsOtherSettings", "merge-photons", "parts with different photon-depth", "{in}/photons_a.h5 {in}/photons_depth.h5 -o {out}", "max_depth"},
    {"MergePhotonsNotAPart", "merge-photons", "a whole photon map given as a part", "{in}/photons_a.h5 {in}/photons.h5 -o {out}", "photons.h5: not a part"},
    {"MergePhotonsTruncated", "merge-photons", "a part cut off midway", "{in}/photons_a.h5 {in}/truncated_photons_b.h5 -o {out}", "truncated_photons_b.h5", "damaged or truncated HDF5 file"},

    // ---- compare-images ----
    {"CompareTestMissing", "compare-images", "test image does not exist", "{in}/missing.exr {in}/image.exr -o {out}", "missing.exr", "No such file or directory"},
    {"CompareReferenceMissing", "compare-images", "reference image does not exist", "{in}/image.exr {in}/missing.exr -o {out}", "missing.exr", "No such file or directory"},
    {"CompareNoReference", "compare-images", "reference left out", "{in}/image.exr -o {out}", "reference"},
    {"CompareNotAnImage", "compare-images", "test image is a text file", "{in}/text.exr {in}/image.exr -o {out}", "text.exr", "not an OpenEXR file"},
    {"CompareTruncatedExr", "compare-images", "EXR cut off midway", "{in}/truncated_image.exr {in}/image.exr -o {out}", "truncated_image.exr", "Early end of file"},
    {"CompareSizeMismatch", "compare-images", "images of different sizes", "{in}/small.exr {in}/image.exr -o {out}", "size"},
    {"CompareBadMask", "compare-images", "--mask not x0,y0,x1,y1", "{in}/image.exr {in}/image.exr --mask 1,2 -o {out}", "--mask"},
    {"CompareBadCrop", "compare-images", "--crop not x0,y0,x1,y1", "{in}/image.exr --srgb-png {out} --crop 1,2", "--crop"},
    {"CompareCropOutside", "compare-images", "--crop beyond the image", "{in}/image.exr --srgb-png {out} --crop 0,0,9999,9999", "--crop"},
    {"CompareOutputDirMissing", "compare-images", "error image folder does not exist", "{in}/image.exr {in}/image.exr -o /nonexistent-dir/e.png", "/nonexistent-dir/e.png", "output directory does not exist"},
};
// clang-format on

INSTANTIATE_TEST_SUITE_P(Catalogue, BadInput, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<BadInputCase>& info) { return std::string(info.param.id); });

}  // namespace
