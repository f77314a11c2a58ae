// <integrator>, <sensor> and what a sensor holds: <film> (with its <rfilter>) and <sampler>.
#include <cmath>
#include <set>

#include "formats/mitsuba/builder.h"

namespace iris::mitsuba {

void SceneBuilder::integrator(const Source& src, pugi::xml_node n) {
    Plugin p = read_plugin(src, n);
    if (have_integrator) fail(src, p.line, "a second <integrator>");
    have_integrator = true;
    for (pugi::xml_node c : p.children)
        if (std::string_view(c.name()) == "integrator")
            fail(src, src.line_of(c), "nested integrators (e.g. irradiance-cache wrappers) are not supported");
    no_children(p);
    // Mitsuba's meaning: maxDepth = longest path in edges, -1 = unlimited; RR from rrDepth on.
    int max_depth = get_int(p, "maxDepth", -1);
    int rr_depth = get_int(p, "rrDepth", 5);
    if (max_depth < -1) fail(src, find(p, "maxDepth")->line, "maxDepth must be -1 (unlimited) or >= 0");
    if (rr_depth < 1) fail(src, find(p, "rrDepth")->line, "rrDepth must be >= 1");
    scene.defaults.max_depth = max_depth;
    scene.defaults.rr_depth = rr_depth;
    finish(p, [](const std::string&) {
        return "a setting of Mitsuba's own integrator; iris takes only maxDepth and rrDepth from it";
    });
}

void SceneBuilder::sensor(const Source& src, pugi::xml_node n) {
    Plugin p = read_plugin(src, n);
    if (have_sensor) fail(src, p.line, "a second <sensor>");
    have_sensor = true;
    if (p.type != "perspective") fail(src, p.line, "unsupported sensor type " + quote(p.type) + " (only perspective)");

    // Film and sampler first: the field of view depends on the aspect ratio.
    FilmSettings film;
    bool have_film = false, have_sampler = false;
    for (pugi::xml_node c : p.children) {
        std::string tag = c.name();
        if (tag == "film") {
            if (have_film) fail(src, src.line_of(c), "a second <film>");
            have_film = true;
            film = read_film(src, c);
        } else if (tag == "sampler") {
            if (have_sampler) fail(src, src.line_of(c), "a second <sampler>");
            have_sampler = true;
            read_sampler(src, c);
        } else {
            fail(src, src.line_of(c), "<" + tag + "> is not allowed inside a sensor");
        }
    }
    scene.film = film;

    Camera& cam = scene.camera;
    cam = Camera();
    cam.to_world = get_transform(p, "toWorld").value_or(Transform());
    std::optional<float> fov = get_float(p, "fov");
    std::optional<std::string> focal = get_string(p, "focalLength");
    if (fov && focal) fail(src, p.line, "give either fov or focalLength, not both");
    if (fov) {
        std::string axis = lower(get_string(p, "fovAxis", "x"));
        if (axis == "x") cam.fov_axis = FovAxis::X;
        else if (axis == "y") cam.fov_axis = FovAxis::Y;
        else if (axis == "diagonal") cam.fov_axis = FovAxis::Diagonal;
        else if (axis == "smaller") cam.fov_axis = FovAxis::Smaller;
        else if (axis == "larger") cam.fov_axis = FovAxis::Larger;
        else fail(src, find(p, "fovAxis")->line, "fovAxis must be x, y, diagonal, smaller or larger, not " + quote(axis));
        cam.fov_degrees = *fov;
    } else {
        // Mitsuba's default: a 50 mm lens on 35 mm film, as a diagonal field of view.
        std::string f = focal.value_or("50mm");
        const int line = focal ? find(p, "focalLength")->line : p.line;
        if (f.size() > 2 && f.compare(f.size() - 2, 2, "mm") == 0) f.resize(f.size() - 2);
        float mm = parse_float(src, line, f, "focalLength");
        if (!(mm > 0)) fail(src, line, "focalLength must be positive");
        cam.fov_degrees = float(2.0 * std::atan(std::sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * mm)) * (180.0 / double(kPi)));
        cam.fov_axis = FovAxis::Diagonal;
        if (find(p, "fovAxis")) get_string(p, "fovAxis");  // meaningless without fov; accepted as Mitsuba does
    }
    if (!(cam.fov_degrees > 0 && cam.fov_degrees < 180)) fail(src, p.line, "fov must lie in (0, 180) degrees");
    cam.near_clip = get_float(p, "nearClip", 1e-2f);
    cam.far_clip = get_float(p, "farClip", 1e4f);
    if (!(cam.near_clip > 0) || !(cam.far_clip > cam.near_clip))
        fail(src, p.line, "need 0 < nearClip < farClip");
    // A pinhole camera has no focus: accepted silently (every Mitsuba exporter writes it).
    get_float(p, "focusDistance");
    finish(p, [](const std::string& name) -> const char* {
        if (name == "shutterOpen" || name == "shutterClose") return "iris renders static scenes (no motion blur)";
        return nullptr;
    });
    camera_prepare(cam, film.width, film.height);
    if (!is_finite(cam.forward) || !is_finite(cam.right) || !is_finite(cam.up))
        fail(src, p.line, "the camera transform is degenerate");
}

FilmSettings SceneBuilder::read_film(const Source& src, pugi::xml_node n) {
    Plugin p = read_plugin(src, n);
    if (p.type != "hdrfilm" && p.type != "ldrfilm")
        fail(src, p.line, "unsupported film type " + quote(p.type) + " (hdrfilm or ldrfilm)");
    FilmSettings film;
    film.width = get_int(p, "width", 768);
    film.height = get_int(p, "height", 576);
    if (film.width <= 0 || film.height <= 0 || film.width > 65536 || film.height > 65536)
        fail(src, p.line, "film width and height must be in 1..65536");
    for (const char* crop : {"cropOffsetX", "cropOffsetY", "cropWidth", "cropHeight"})
        if (Prop* c = find(p, crop)) fail(src, c->line, "crop windows (" + std::string(crop) + ") are not supported");
    bool have_filter = false;
    for (pugi::xml_node c : p.children) {
        if (std::string_view(c.name()) != "rfilter")
            fail(src, src.line_of(c), std::string("<") + c.name() + "> is not allowed inside a film");
        if (have_filter) fail(src, src.line_of(c), "a second <rfilter>");
        have_filter = true;
        Plugin f = read_plugin(src, c);
        no_children(f);
        if (f.type == "gaussian") {
            // Mitsuba: standard deviation 0.5 px, support 4 standard deviations.
            film.filter = FilterType::Gaussian;
            film.filter_stddev = get_float(f, "stddev", 0.5f);
            if (!(film.filter_stddev > 0)) fail(src, f.line, "stddev must be positive");
            film.filter_radius = 4.0f * film.filter_stddev;
        } else if (f.type == "box") {
            film.filter = FilterType::Box;
            film.filter_radius = get_float(f, "radius", 0.5f);
            if (!(film.filter_radius > 0)) fail(src, f.line, "radius must be positive");
        } else {
            fail(src, f.line, "unsupported reconstruction filter " + quote(f.type) + " (gaussian or box)");
        }
        finish(f);
    }
    finish(p, [](const std::string& name) -> const char* {
        static const std::set<std::string> output = {"banner",   "pixelFormat", "componentFormat", "fileFormat",
                                                     "tonemapMethod", "gamma", "exposure", "highQualityEdges",
                                                     "attachLog", "key", "burn"};
        if (output.count(name) || name.rfind("label[", 0) == 0)
            return "an output-format setting; iris writes linear HDR images";
        return nullptr;
    });
    return film;
}

void SceneBuilder::read_sampler(const Source& src, pugi::xml_node n) {
    Plugin p = read_plugin(src, n);
    no_children(p);
    if (auto spp = get_int(p, "sampleCount")) {
        if (*spp <= 0) fail(src, find(p, "sampleCount")->line, "sampleCount must be positive");
        scene.defaults.spp = *spp;
    }
    finish(p, [](const std::string&) { return "iris uses its own sample generator; only sampleCount is taken"; });
}

}  // namespace iris::mitsuba
