// <emitter> plugins: point, spot, directional, constant and envmap at the top level (each one
// builder function registered in kEmitters; sky, sun and sunsky are in sunsky.cpp), and the area
// emitter nested in a shape.
#include <algorithm>
#include <cmath>

#include "formats/image_file.h"
#include "formats/mitsuba/builder.h"

namespace iris::mitsuba {
namespace {

// Fills `l` (type, position, direction, radiance, ...) from the element `e`.
using EmitterBuilder = void (*)(SceneBuilder& b, Plugin& e, Light* l);

float sampling_weight(SceneBuilder& b, Plugin& e) {
    float w = b.get_float(e, "samplingWeight", 1.0f);
    if (!(w > 0)) fail(*e.src, b.find(e, "samplingWeight")->line, "samplingWeight must be positive");
    return w;
}

void check_radiance(const Plugin& e, RGB c) {
    if (!is_finite(c) || c.r < 0 || c.g < 0 || c.b < 0)
        fail(*e.src, e.line, e.what() + ": emission must be finite and non-negative");
}

// A light's unit direction from a parameter (or toWorld's image of +z); zero or non-finite fails.
Vec3 light_direction(SceneBuilder& b, Plugin& e, Vec3 d, const char* from) {
    const float len = length(d);
    if (!(len > 0) || !std::isfinite(len)) {
        Prop* p = b.find(e, from);
        fail(*e.src, p ? p->line : e.line, e.what() + ": " + from + " gives no direction (zero or not finite)");
    }
    return d / len;
}

void point(SceneBuilder& b, Plugin& e, Light* l) {
    l->type = LightType::Point;
    std::optional<Vec3> pos = b.get_point(e, "position");
    std::optional<Transform> m = b.get_transform(e, "toWorld");
    if (pos && m) fail(*e.src, e.line, "give either position or toWorld for a point light, not both");
    l->position = pos ? *pos : m ? m->point(Vec3(0.0f)) : Vec3(0.0f);
    l->radiance = b.get_spectrum(e, "intensity", RGB(1.0f));  // W/sr
}

void spot(SceneBuilder& b, Plugin& e, Light* l) {
    l->type = LightType::Spot;
    const Transform m = b.get_transform(e, "toWorld").value_or(Transform());
    l->position = m.point(Vec3(0.0f));
    l->direction = light_direction(b, e, m.vector(Vec3(0, 0, 1)), "toWorld");
    l->radiance = b.get_spectrum(e, "intensity", RGB(1.0f));  // W/sr on the axis
    const float cutoff = b.get_float(e, "cutoffAngle", 20.0f);  // degrees, Mitsuba's defaults
    const float beam = b.get_float(e, "beamWidth", cutoff * 0.75f);
    if (!(cutoff > 0 && cutoff <= 180))
        fail(*e.src, b.find(e, "cutoffAngle")->line, "cutoffAngle must be in (0, 180] degrees");
    if (!(beam >= 0 && beam <= cutoff)) {
        Prop* bp = b.find(e, "beamWidth");
        fail(*e.src, bp ? bp->line : e.line, "beamWidth must be in [0, cutoffAngle] degrees");
    }
    l->cutoff = cutoff * (kPi / 180.0f);
    l->beam_width = beam * (kPi / 180.0f);
    l->cos_cutoff = std::cos(l->cutoff);
}

void directional(SceneBuilder& b, Plugin& e, Light* l) {
    l->type = LightType::Directional;
    std::optional<Vec3> dir = b.get_point(e, "direction");
    std::optional<Transform> m = b.get_transform(e, "toWorld");
    if (dir && m) fail(*e.src, e.line, "give either direction or toWorld for a directional light, not both");
    l->direction = light_direction(b, e, dir ? *dir : m ? m->vector(Vec3(0, 0, 1)) : Vec3(0, 0, 1),
                                   dir ? "direction" : "toWorld");
    l->radiance = b.get_spectrum(e, "irradiance", RGB(1.0f));  // W/m^2
}

void constant(SceneBuilder& b, Plugin& e, Light* l) {
    l->type = LightType::Constant;
    l->radiance = b.get_spectrum(e, "radiance", RGB(1.0f));
}

// A latitude-longitude image file -> its texels in linear RGB times `scale`.
std::vector<RGB> envmap_texels(const Source& src, int fline, const std::string& file, const fs::path& path,
                               float scale, int* width, int* height) {
    Image img;
    bool display_encoded = false;
    try {
        ImageFile f = read_image_file(path.string());
        img = std::move(f.image);
        display_encoded = f.display_encoded;
    } catch (const std::exception& ex) {
        fail(src, fline, "envmap " + quote(file) + ": " + ex.what());
    }
    // PNG/JPEG maps hold sRGB-encoded values (Mitsuba decodes them so); EXR/HDR are linear radiance.
    if (display_encoded)
        for (int c : {img.channel_index("R"), img.channel_index("G"), img.channel_index("B")})
            if (c >= 0)
                for (float& v : img.data[size_t(c)])
                    v = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
    const int ri = img.channel_index("R"), gi = img.channel_index("G"), bi = img.channel_index("B");
    const int yi = img.channel_index("Y");
    if ((ri < 0 || gi < 0 || bi < 0) && yi < 0)
        fail(src, fline, "envmap " + quote(file) + " has neither R, G, B nor Y channels");
    std::vector<RGB> texels(size_t(std::max(0, img.width)) * size_t(std::max(0, img.height)));
    for (size_t i = 0; i < texels.size(); ++i)
        texels[i] = ri >= 0 && gi >= 0 && bi >= 0 ? RGB(img.data[ri][i], img.data[gi][i], img.data[bi][i]) * scale
                                                 : RGB(img.data[yi][i]) * scale;
    *width = img.width;
    *height = img.height;
    return texels;
}

// emitter "envmap": a latitude-longitude image (EXR or Radiance HDR; PNG/JPEG decoded from sRGB),
// times `scale`, oriented by toWorld (Mitsuba 0.5: +y up in the map's frame).
void envmap(SceneBuilder& b, Plugin& e, Light* l) {
    const Source& src = *e.src;
    l->type = LightType::Envmap;
    std::optional<std::string> file = b.get_string(e, "filename");
    if (!file) fail(src, e.line, "emitter \"envmap\" needs a filename");
    const int fline = b.find(e, "filename")->line;
    const float scale = b.get_float(e, "scale", 1.0f);
    if (!(scale >= 0) || !std::isfinite(scale)) fail(src, b.find(e, "scale")->line, "envmap scale must be finite and >= 0");
    const Transform to_world = b.get_transform(e, "toWorld").value_or(Transform());
    if (!(std::abs(to_world.determinant3x3()) > 0)) fail(src, b.find(e, "toWorld")->line, "envmap toWorld is singular");
    if (b.find(e, "gamma")) b.get_float(e, "gamma");  // for LDR maps in Mitsuba; EXR/HDR are linear
    b.get_bool(e, "cache", false);                      // Mitsuba's MIP-map cache switch: no meaning here
    const fs::path path = b.resolve(src, *file);
    std::string bytes;
    if (!read_file(path, &bytes))
        fail(src, fline, "cannot read envmap file " + quote(*file) + " (resolved to " + path.string() + ")");
    b.fingerprint.add(bytes);
    int width = 0, height = 0;
    std::vector<RGB> texels = envmap_texels(src, fline, *file, path, scale, &width, &height);
    try {
        l->envmap = make_envmap(width, height, std::move(texels), to_world);
    } catch (const std::invalid_argument& ex) {
        fail(src, fline, "envmap " + quote(*file) + ": " + ex.what());
    }
}

// Mitsuba renders the sum of several environment emitters (a `sun` beside a `sky`, a `constant` fill
// beside an `envmap`); iris keeps one environment light, so a second one is added into the first:
// constants add, a constant adds to every texel of a map, and two maps add texel by texel when they have
// the same size and toWorld. The sum emits the same radiance from every direction, and is sampled by its
// total luminance. False (nothing changed) where the two cannot be added so.
bool add_environment(Light* into, const Light& l) {
    if (into->sampling_weight != l.sampling_weight) return false;
    if (into->type == LightType::Constant && l.type == LightType::Constant) {
        into->radiance = into->radiance + l.radiance;
        return true;
    }
    const bool into_map = into->type == LightType::Envmap;
    const EnvMap& base = into_map ? *into->envmap : *l.envmap;
    const Light& other = into_map ? l : *into;
    std::vector<RGB> texels = base.texels;
    if (other.type == LightType::Constant) {
        for (RGB& t : texels) t = t + other.radiance;
    } else {
        const EnvMap& m = *other.envmap;
        if (m.width != base.width || m.height != base.height) return false;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                if (m.to_world.m[i][j] != base.to_world.m[i][j]) return false;
        for (size_t i = 0; i < texels.size(); ++i) texels[i] = texels[i] + m.texels[i];
    }
    into->envmap = make_envmap(base.width, base.height, std::move(texels), base.to_world);
    into->type = LightType::Envmap;
    into->radiance = RGB(0.0f);
    return true;
}

// The emitter plugins (an area emitter is nested in its shape: SceneBuilder::area_emitter).
struct EmitterPlugin {
    const char* name;
    EmitterBuilder build;
};
const EmitterPlugin kEmitters[] = {
    {"point", point}, {"spot", spot}, {"directional", directional}, {"constant", constant}, {"envmap", envmap},
    {"sky", sky_emitter}, {"sun", sun_emitter}, {"sunsky", sunsky_emitter},
};

}  // namespace

void SceneBuilder::emitter(const Source& src, pugi::xml_node n) {
    Plugin e = read_plugin(src, n);
    no_children(e);
    const EmitterPlugin* plugin = nullptr;
    std::vector<std::string> names;
    for (const EmitterPlugin& k : kEmitters) {
        names.push_back(k.name);
        if (e.type == k.name) plugin = &k;
    }
    if (e.type == "area") fail(src, e.line, "an area emitter must be nested inside the shape that emits");
    if (!plugin)
        fail(src, e.line, "unsupported emitter type " + quote(e.type) + " (" + name_list(names, ", ") +
                              ", or area on shapes)");
    Light l;
    plugin->build(*this, e, &l);
    const bool env = l.type == LightType::Constant || l.type == LightType::Envmap;
    l.sampling_weight = sampling_weight(*this, e);
    check_radiance(e, l.radiance);
    finish(e);
    if (env)
        for (Light& other : scene.lights)
            if (other.type == LightType::Constant || other.type == LightType::Envmap) {
                if (!add_environment(&other, l))
                    fail(src, e.line,
                         "a second environment emitter that cannot be added to the first (maps of another size or "
                         "orientation, or another samplingWeight): iris keeps one environment light per scene");
                return;
            }
    scene.lights.push_back(l);
    if (env) scene.environment_light = int(scene.lights.size() - 1);
}

void SceneBuilder::area_emitter(const Source& src, pugi::xml_node n, LightType type, uint32_t shape_index) {
    Plugin e = read_plugin(src, n);
    if (e.type != "area") fail(src, e.line, "only area emitters can be attached to a shape, not " + quote(e.type));
    no_children(e);
    Light l;
    l.type = type;
    l.shape = shape_index;
    l.radiance = get_spectrum(e, "radiance", RGB(1.0f));
    l.sampling_weight = sampling_weight(*this, e);
    check_radiance(e, l.radiance);
    finish(e);
    scene.lights.push_back(l);
    const int32_t li = int32_t(scene.lights.size() - 1);
    if (type == LightType::AreaSphere) scene.spheres[shape_index].light = li;
    else scene.meshes[shape_index].light = li;
}

}  // namespace iris::mitsuba
