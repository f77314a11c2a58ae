// export-scene: the scene as iris loaded it, as JSON, for other renderers (scripts/cycles_render.py).
// World-space triangles (after every toWorld), analytic spheres, BSDFs with the RGB values iris derived
// from the file's spectra, lights' radiance, and the camera's prepared basis for one film size: a peer
// renderer rebuilt from this file sees the numbers iris renders, not its own reading of the XML.
//   export-scene scene.xml -o scene.json [--resolution 256x256]
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <unistd.h>

#include "formats/atomic_file.h"
#include "formats/scene_xml.h"
#include "libcommon/camera.h"
#include "tools/common/tool_util.h"

namespace {

const char* bsdf_type_name(iris::BsdfType t) {
    switch (t) {
        case iris::BsdfType::Diffuse: return "diffuse";
        case iris::BsdfType::Dielectric: return "dielectric";
        case iris::BsdfType::Conductor: return "conductor";
        default: return "other";  // the peer refuses these (no equivalent set up)
    }
}

struct Out {
    std::string s;
    void num(double v) {
        if (!std::isfinite(v)) throw std::runtime_error("non-finite value in the scene");
        char b[32];
        std::snprintf(b, sizeof b, "%.9g", v);
        s += b;
    }
    void vec(double x, double y, double z) {
        s += '[';
        num(x); s += ',';
        num(y); s += ',';
        num(z); s += ']';
    }
    void rgb(const iris::RGB& c) { vec(c.r, c.g, c.b); }
    void v3(const iris::Vec3& v) { vec(v.x, v.y, v.z); }
};

}  // namespace

int main(int argc, char** argv) {
    std::string path, output, resolution;
    std::vector<std::string> defines;
    CLI::App app{"export-scene: a loaded iris scene as JSON (world-space geometry, RGB materials, camera)"};
    app.set_version_flag("--version", std::string("iris export-scene ") + IRIS_VERSION);
    app.add_option("scene", path, "Mitsuba XML scene")->required();
    app.add_option("-o,--output", output, "JSON file to write")->required();
    app.add_option("--resolution", resolution, "Film size WxH the camera is prepared for (default: the scene's)");
    app.add_option("-D,--define", defines, "Scene parameter name=value (for $name in the scene file)");
    bool strict = false;
    std::string interpolation = "linear";
    iris::add_strict_option(app, &strict);
    iris::add_spectrum_interpolation_option(app, &interpolation);
    if (int rc = iris::parse_command_line(app, argc, argv, "export-scene"); rc >= 0) return rc;
    try {
        iris::check_output_path(output);
        iris::SceneLoadOptions opt;
        opt.parameters = iris::parse_defines(defines);
        opt.strict = strict;
        opt.spectrum_interpolation = interpolation == "linear" ? iris::SpectrumInterpolation::Linear
                                                               : iris::SpectrumInterpolation::Mitsuba050;
        iris::Scene scene = iris::parse_scene(path, opt);
        int w = scene.film.width, h = scene.film.height;
        if (!resolution.empty()) iris::parse_resolution(resolution, &w, &h);
        iris::Camera cam = scene.camera;
        iris::camera_prepare(cam, w, h);
        for (const iris::Bsdf& b : scene.bsdfs)
            if (std::string(bsdf_type_name(b.type)) == "other")
                throw std::runtime_error(path + ": a BSDF type export-scene does not translate (diffuse, dielectric, "
                                                "conductor only)");
        // A texture is refused rather than exported as its mean: the peer would render a different
        // picture under the same numbers, and the comparison this file exists for would be void.
        for (const iris::Bsdf& b : scene.bsdfs)
            if (iris::bsdf_has_textures(b))  // (parse_scene: bsdf_prepare has not run, b.textured is unset)
                throw std::runtime_error(path + ": a textured BSDF parameter (export-scene writes constant "
                                                "parameters only)");
        // Likewise a mask: the peer has no opacity, and would render the surface opaque.
        for (const iris::Bsdf& b : scene.bsdfs)
            if (iris::bsdf_is_masked(b))
                throw std::runtime_error(path + ": a mask BSDF (export-scene writes opaque surfaces only)");
        for (const iris::Light& l : scene.lights)
            if (l.type != iris::LightType::AreaMesh && l.type != iris::LightType::AreaSphere)
                throw std::runtime_error(path + ": a light type export-scene does not translate (area only)");
        Out o;
        o.s += "{\"scene\":\"";
        for (char c : path) {
            if (c == '"' || c == '\\') o.s += '\\';
            o.s += c;
        }
        o.s += "\",\"fingerprint\":\"" + scene.fingerprint + "\",\"width\":" + std::to_string(w) +
               ",\"height\":" + std::to_string(h) + ",\"max_depth\":" + std::to_string(scene.defaults.max_depth) +
               ",\"rr_depth\":" + std::to_string(scene.defaults.rr_depth);
        // Image +x = right, image -y = up (rows grow downwards); tangents of the half fields of view.
        o.s += ",\"camera\":{\"origin\":"; o.v3(cam.origin);
        o.s += ",\"right\":"; o.v3(cam.right);
        o.s += ",\"up\":"; o.v3(cam.up);
        o.s += ",\"forward\":"; o.v3(cam.forward);
        o.s += ",\"tan_half_x\":"; o.num(cam.tan_half_x);
        o.s += ",\"tan_half_y\":"; o.num(cam.tan_half_y);
        o.s += ",\"near\":"; o.num(cam.near_clip);
        o.s += ",\"far\":"; o.num(cam.far_clip);
        o.s += "},\"filter\":{\"type\":\"";
        o.s += scene.film.filter == iris::FilterType::Box ? "box" : "gaussian";
        o.s += "\",\"stddev\":"; o.num(scene.film.filter_stddev);
        o.s += ",\"radius\":"; o.num(scene.film.filter_radius);
        o.s += "},\"bsdfs\":[";
        for (size_t i = 0; i < scene.bsdfs.size(); ++i) {
            const iris::Bsdf& b = scene.bsdfs[i];
            o.s += i ? ",{" : "{";
            o.s += "\"type\":\"" + std::string(bsdf_type_name(b.type)) + "\",\"two_sided\":";
            o.s += b.two_sided ? "true" : "false";
            o.s += ",\"diffuse\":"; o.rgb(b.diffuse);
            o.s += ",\"specular\":"; o.rgb(b.specular);
            o.s += ",\"transmittance\":"; o.rgb(b.transmittance);
            o.s += ",\"ior\":"; o.num(b.ior);
            o.s += ",\"eta\":"; o.rgb(b.eta);
            o.s += ",\"k\":"; o.rgb(b.k);
            o.s += "}";
        }
        o.s += "],\"lights\":[";
        for (size_t i = 0; i < scene.lights.size(); ++i) {
            o.s += i ? ",{\"radiance\":" : "{\"radiance\":";
            o.rgb(scene.lights[i].radiance);  // W/(m^2 sr), one-sided
            o.s += "}";
        }
        o.s += "],\"spheres\":[";
        for (size_t i = 0; i < scene.spheres.size(); ++i) {
            const iris::Sphere& s = scene.spheres[i];
            o.s += i ? ",{\"center\":" : "{\"center\":";
            o.v3(s.center);
            o.s += ",\"radius\":"; o.num(s.radius);
            o.s += ",\"bsdf\":" + std::to_string(s.bsdf) + ",\"light\":" + std::to_string(s.light) + "}";
        }
        o.s += "],\"meshes\":[";
        for (size_t i = 0; i < scene.meshes.size(); ++i) {
            const iris::Mesh& m = scene.meshes[i];
            o.s += i ? ",{" : "{";
            o.s += "\"bsdf\":" + std::to_string(m.bsdf) + ",\"light\":" + std::to_string(m.light) +
                   ",\"flip_normals\":" + (m.flip_normals ? "true" : "false") + ",\"positions\":[";
            for (size_t k = 0; k < m.positions.size(); ++k) {
                if (k) o.s += ',';
                o.v3(m.positions[k]);
            }
            o.s += "],\"normals\":[";
            for (size_t k = 0; k < m.normals.size(); ++k) {
                if (k) o.s += ',';
                o.v3(m.normals[k]);
            }
            o.s += "],\"indices\":[";
            for (size_t k = 0; k < m.indices.size(); ++k) {
                if (k) o.s += ',';
                o.s += std::to_string(m.indices[k]);
            }
            o.s += "]}";
        }
        o.s += "]}\n";
        iris::AtomicFile f(output);
        size_t done = 0;
        while (done < o.s.size()) {
            const ssize_t n = ::write(f.fd(), o.s.data() + done, o.s.size() - done);
            if (n <= 0) throw std::runtime_error(output + ": write failed");
            done += size_t(n);
        }
        f.commit();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "export-scene: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
