// <texture> plugins: Mitsuba's textures on BSDF parameters. `bitmap` (an image file),
// `checkerboard`, and `scale` (a texture times a constant), nested in the BSDF (<texture
// name="reflectance" ...>) or declared at the top level with an id and referenced (<ref
// name="reflectance" id="..."/>). Each distinct texture becomes one Scene::textures entry: repeated
// references share it, and an image file is decoded (and fingerprinted) once however many textures
// read it. Each plugin is one builder function registered in kTextures.
#include <cstdio>

#include "formats/mitsuba/builder.h"
#include "formats/texture_file.h"

namespace iris::mitsuba {
namespace {

// Builds the texture of element `p` and returns its index in scene.textures. `context` names
// where the texture stands, for messages.
using TextureBuilder = int16_t (*)(SceneBuilder& b, Plugin& p, const std::string& context);

WrapMode wrap_mode(SceneBuilder& b, Plugin& p, const std::string& name, WrapMode def) {
    std::optional<std::string> w = b.get_string(p, name);
    if (!w) return def;
    const std::string v = lower(*w);
    if (v == "repeat") return WrapMode::Repeat;
    if (v == "mirror") return WrapMode::Mirror;
    if (v == "clamp") return WrapMode::Clamp;
    if (v == "zero") return WrapMode::Zero;
    if (v == "one") return WrapMode::One;
    fail(*p.src, b.find(p, name)->line, name + " must be repeat, mirror, clamp, zero or one, not " + quote(*w));
}

std::string key_of(const Texture& t) {
    char b[160];
    std::snprintf(b, sizeof b, "|%d|%d|%d|%a|%a|%a|%a|%a|%a|%a|%a|%a|%a", int(t.wrap_u), int(t.wrap_v),
                  int(t.filter), t.uscale, t.vscale, t.uoffset, t.voffset, t.color0.r, t.color0.g, t.color0.b,
                  t.color1.r, t.color1.g, t.color1.b);
    return b;
}

std::string texture_options_key(const BitmapOptions& o) {
    char b[128];
    std::snprintf(b, sizeof b, "|%d|%d|%d|%a|%a|%a|%a", int(o.filter), int(o.wrap_u), int(o.wrap_v), o.uscale,
                  o.vscale, o.uoffset, o.voffset);
    return b;
}

// A bitmap's parameters other than the file: how it is decoded and sampled.
BitmapOptions bitmap_options(SceneBuilder& b, Plugin& p) {
    const Source& src = *p.src;
    BitmapOptions o;
    o.gamma = b.get_float(p, "gamma", 0.0f);
    if (!(o.gamma == 0.0f || o.gamma == -1.0f || o.gamma > 0.0f))
        fail(src, b.find(p, "gamma")->line, "gamma must be 0 (automatic), -1 (sRGB) or positive");
    o.channel = lower(b.get_string(p, "channel", ""));
    const std::string filter = lower(b.get_string(p, "filterType", "ewa"));
    if (filter == "nearest") o.filter = TextureFilter::Nearest;
    else if (filter == "ewa" || filter == "trilinear") o.filter = TextureFilter::Bilinear;
    else fail(src, b.find(p, "filterType")->line, "filterType must be ewa, trilinear or nearest, not " + quote(filter));
    if (Prop* f = b.find(p, "filterType"); f && filter != "nearest")
        b.warn(src, f->line, "filterType " + quote(filter) + " read as bilinear: iris has no MIP-map filtering "
                             "(pixel averages converge to the same values, with more noise where a texture is minified)");
    const WrapMode both = wrap_mode(b, p, "wrapMode", WrapMode::Repeat);
    o.wrap_u = wrap_mode(b, p, "wrapModeU", both);
    o.wrap_v = wrap_mode(b, p, "wrapModeV", both);
    Texture shape;
    b.uv_transform(p, &shape);
    o.uscale = shape.uscale;
    o.vscale = shape.vscale;
    o.uoffset = shape.uoffset;
    o.voffset = shape.voffset;
    return o;
}

// Reads and decodes an image file into a texture's texels (the file is added to the fingerprint
// once). `fline`: the line of the filename parameter.
Texture decode_bitmap(SceneBuilder& b, const Source& src, int fline, const std::string& file, const fs::path& path,
                      const BitmapOptions& o) {
    std::string bytes;
    if (!read_file(path, &bytes))
        fail(src, fline, "cannot read texture file " + quote(file) + " (resolved to " + path.string() + ")");
    if (!b.hashed_files.count(path.lexically_normal().string())) {
        b.fingerprint.add(bytes);
        b.hashed_files.insert(path.lexically_normal().string());
    }
    bytes = std::string();
    Texture t;
    try {
        t = load_bitmap_texture(path.string(), o);
    } catch (const std::exception& e) {
        fail(src, fline, "texture " + quote(file) + ": " + e.what());
    }
    if (t.width <= 0 || t.height <= 0 || t.texels.empty())
        fail(src, fline, "texture " + quote(file) + " has no pixels (" + std::to_string(t.width) + " x " +
                             std::to_string(t.height) + ")");
    for (size_t i = 0; i < t.texels.size(); ++i) {
        const RGB c = t.texels[i];
        if (!is_finite(c) || c.r < 0 || c.g < 0 || c.b < 0)
            fail(src, fline, "texture " + quote(file) + " has a negative or non-finite value at pixel (" +
                                 std::to_string(i % size_t(t.width)) + ", " + std::to_string(i / size_t(t.width)) +
                                 "); BSDF parameters must be finite and non-negative");
    }
    return t;
}

int16_t bitmap(SceneBuilder& b, Plugin& p, const std::string&) {
    const Source& src = *p.src;
    b.no_children(p);
    std::optional<std::string> file = b.get_string(p, "filename");
    if (!file) fail(src, p.line, "texture \"bitmap\" needs a filename");
    const int fline = b.find(p, "filename")->line;
    const BitmapOptions o = bitmap_options(b, p);
    b.finish(p, [](const std::string& name) -> const char* {
        if (name == "maxAnisotropy") return "it tunes EWA filtering, which iris does not do";
        if (name == "cache") return "Mitsuba's MIP-map cache switch; iris builds no MIP maps";
        return nullptr;
    });
    const fs::path path = b.resolve(src, *file);
    const std::string decode_key = path.lexically_normal().string() + "|" + std::to_string(o.gamma) + "|" + o.channel;
    Texture t;
    if (auto it = b.decoded_by_file.find(decode_key); it != b.decoded_by_file.end())
        t = b.scene.textures[size_t(it->second)];  // the same texels, perhaps sampled differently
    else
        t = decode_bitmap(b, src, fline, *file, path, o);
    set_bitmap_sampling(o, &t);  // a shared decoded file may be sampled differently
    const bool fresh = !b.decoded_by_file.count(decode_key);
    const int16_t index = b.add_texture(std::move(t), "bitmap|" + decode_key + texture_options_key(o));
    if (fresh) b.decoded_by_file.emplace(decode_key, index);
    return index;
}

int16_t checkerboard(SceneBuilder& b, Plugin& p, const std::string&) {
    b.no_children(p);
    Texture t;
    t.type = TextureType::Checkerboard;
    t.color0 = b.get_spectrum(p, "color0", RGB(0.4f));
    t.color1 = b.get_spectrum(p, "color1", RGB(0.2f));
    for (const RGB* c : {&t.color0, &t.color1})
        if (!is_finite(*c) || c->r < 0 || c->g < 0 || c->b < 0)
            fail(*p.src, p.line, "checkerboard colours must be finite and non-negative");
    b.uv_transform(p, &t);
    b.finish(p);
    const std::string key = "checkerboard" + key_of(t);
    return b.add_texture(std::move(t), key);
}

// Mitsuba's `scale`: a nested texture times `scale` (a number or a colour), baked into the texels.
int16_t scale(SceneBuilder& b, Plugin& p, const std::string& context) {
    const Source& src = *p.src;
    if (p.children.size() != 1) fail(src, p.line, "texture \"scale\" needs exactly one nested <texture> or <ref>");
    pugi::xml_node c = p.children[0];
    const std::string tag = c.name();
    int16_t inner = -1;
    if (tag == "texture") inner = b.parse_texture(src, c, context);
    else if (tag == "ref") inner = b.texture_ref(src, c);
    else fail(src, src.line_of(c), "<" + tag + "> is not allowed inside texture \"scale\"");
    RGB k(1.0f);
    if (Prop* sp = b.find(p, "scale"); sp && (sp->kind == Kind::Float || sp->kind == Kind::Integer))
        k = RGB(*b.get_float(p, "scale"));
    else
        k = b.get_spectrum(p, "scale", RGB(1.0f));
    if (!is_finite(k) || k.r < 0 || k.g < 0 || k.b < 0)
        fail(src, b.find(p, "scale")->line, "the scale of texture \"scale\" must be finite and non-negative");
    b.finish(p);
    Texture t = b.scene.textures[size_t(inner)];
    for (RGB& v : t.texels) v = v * k;
    t.color0 = t.color0 * k;
    t.color1 = t.color1 * k;
    char key[96];
    std::snprintf(key, sizeof key, "scale|%d|%a|%a|%a", int(inner), k.r, k.g, k.b);
    return b.add_texture(std::move(t), key);
}

// The texture plugins.
struct TexturePlugin {
    const char* name;
    TextureBuilder build;
};
const TexturePlugin kTextures[] = {
    {"bitmap", bitmap},
    {"checkerboard", checkerboard},
    {"scale", scale},
};

}  // namespace

bool texture_type_supported(const std::string& type) {
    for (const TexturePlugin& k : kTextures)
        if (type == k.name) return true;
    return false;
}

void SceneBuilder::top_level_texture(const Source& src, pugi::xml_node n) {
    const int line = src.line_of(n);
    const std::string id = opt_attr(src, n, "id").value_or("");
    parse_texture(src, n, "texture", true);
    if (id.empty()) warn(src, line, "a top-level texture without an id can never be used");
}

int16_t SceneBuilder::texture_ref(const Source& src, pugi::xml_node n) {
    check_attrs(src, n, {"id", "name"});
    check_no_text(src, n);
    const int line = src.line_of(n);
    const std::string id = attr(src, n, "id");
    auto it = named_textures.find(id);
    if (it == named_textures.end()) {
        check_not_unbuilt(src, line, id);
        if (const IdInfo* known = id_info(id))
            fail(src, line, "<ref id=" + quote(id) + "> refers to a <" + known->tag + ">, not to a texture");
        fail(src, line, "undefined reference " + quote(id) + " (a texture must be declared before it is referenced)");
    }
    it->second.used = true;
    return it->second.index;
}

void SceneBuilder::uv_transform(Plugin& p, Texture* t) {
    const float uv = get_float(p, "uvscale", 1.0f);
    t->uscale = get_float(p, "uscale", uv);
    t->vscale = get_float(p, "vscale", uv);
    t->uoffset = get_float(p, "uoffset", 0.0f);
    t->voffset = get_float(p, "voffset", 0.0f);
}

int16_t SceneBuilder::add_texture(Texture t, const std::string& key) {
    if (auto it = texture_by_key.find(key); it != texture_by_key.end()) return it->second;
    if (scene.textures.size() >= size_t(INT16_MAX))
        throw SceneError("more than " + std::to_string(INT16_MAX) + " distinct textures");
    scene.textures.push_back(std::move(t));
    const int16_t i = int16_t(scene.textures.size() - 1);
    texture_by_key.emplace(key, i);
    return i;
}

int16_t SceneBuilder::parse_texture(const Source& src, pugi::xml_node n, const std::string& context, bool top_level) {
    Plugin p = read_plugin(src, n);
    const TexturePlugin* plugin = nullptr;
    std::vector<std::string> names;
    for (const TexturePlugin& k : kTextures) {
        names.push_back(k.name);
        if (p.type == k.name) plugin = &k;
    }
    if (!plugin)
        fail(src, p.line, "unsupported plugin " + quote(p.type) + " (" + context + "; iris reads " +
                              name_list(names, " and ") + " textures)");
    const int16_t index = plugin->build(*this, p, context);
    if (!p.id.empty()) {
        NamedTexture nt;
        nt.index = index;
        nt.src = &src;
        nt.line = p.line;
        nt.used = !top_level;  // a nested texture is used where it stands
        named_textures[p.id] = nt;
    }
    return index;
}

}  // namespace iris::mitsuba
