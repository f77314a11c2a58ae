// <bsdf> plugins. Each plugin is one builder function registered in kBsdfs (bottom of the
// anonymous namespace); parse_bsdf reads the element, hands it to the builder, then rejects every
// parameter the builder did not query and checks the result.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "formats/mitsuba/builder.h"

namespace iris::mitsuba {
namespace {

// A BSDF parameter given by a texture (textures.cpp): which one, and where.
struct TexParam {
    int16_t index = -1;
    int line = 0;
    bool used = false;
};
using TexParams = std::map<std::string, TexParam>;

// What a builder gets: the element, its textured parameters (nested <texture>s and <ref>s by the
// parameter they give), the BSDF to fill (Mitsuba's default diffuse on entry) and the rule for
// parameters it accepts without using them.
struct BsdfArgs {
    SceneBuilder& b;
    Plugin& p;
    TexParams& tex;
    Bsdf& bsdf;
    IgnoreRule& ignore;
};
using BsdfBuilder = void (*)(BsdfArgs& a);

// ---- parameters shared by the plugins ----------------------------------------------------------

// Parameters the BSDF plugins take as constants only (a texture for one is refused by name).
bool known_constant_param(const std::string& name) {
    static const char* const kNames[] = {"intIOR", "extIOR", "eta", "k", "extEta", "material", "distribution",
                                         "nonlinear", "variant", "useFastApprox", "sampleVisible"};
    return std::find(std::begin(kNames), std::end(kNames), name) != std::end(kNames);
}

// The BSDF's nested <texture> and <ref> children, by the parameter each gives.
TexParams bsdf_textures(SceneBuilder& b, Plugin& p) {
    TexParams out;
    const Source& src = *p.src;
    for (pugi::xml_node c : p.children) {
        const std::string tag = c.name();
        const int line = src.line_of(c);
        if (tag != "texture" && tag != "ref") fail(src, line, "<" + tag + "> is not allowed inside " + p.what());
        const std::optional<std::string> name = b.opt_attr(src, c, "name");
        if (!name || name->empty())
            fail(src, line, "a <" + tag + "> inside " + p.what() + " needs a name (the parameter it gives)");
        if (Prop* prop = b.find(p, *name))
            fail(src, line, "parameter " + quote(*name) + " given twice (first at line " + std::to_string(prop->line) + ")");
        if (auto it = out.find(*name); it != out.end())
            fail(src, line, "parameter " + quote(*name) + " given twice (first at line " + std::to_string(it->second.line) + ")");
        TexParam tp;
        tp.line = line;
        tp.index = tag == "texture" ? b.parse_texture(src, c, "texture for parameter " + quote(*name) + " of " + p.what())
                                    : b.texture_ref(src, c);
        out[*name] = tp;
    }
    return out;
}

// A constant or textured colour parameter: the constant (or `def`) with *tex_index = -1, or
// `def` with *tex_index naming the texture.
RGB spectrum_param(BsdfArgs& a, const std::string& name, RGB def, int16_t* tex_index) {
    auto it = a.tex.find(name);
    if (it == a.tex.end()) return a.b.get_spectrum(a.p, name, def);
    it->second.used = true;
    *tex_index = it->second.index;
    return def;
}

float alpha_param(SceneBuilder& b, Plugin& p, const std::string& name, float def) {
    float a = b.get_float(p, name, def);
    if (a < 0) fail(*p.src, b.find(p, name)->line, name + " must not be negative");
    // Mitsuba clamps roughness to 1e-4: smaller values are numerically a mirror.
    return std::max(a, 1e-4f);
}
// The same, or a texture (its mean over R, G, B at the hit: Bsdf::tex_alpha_*).
float alpha_param(BsdfArgs& a, const std::string& name, float def, int16_t* tex_index) {
    auto it = a.tex.find(name);
    if (it == a.tex.end()) return alpha_param(a.b, a.p, name, def);
    it->second.used = true;
    *tex_index = it->second.index;
    return def;
}

// Roughness as Mitsuba's microfacet models take it: either `alpha` (isotropic) or both `alphaU`
// and `alphaV`; default 0.1. Each may be a texture.
void anisotropic_alpha(BsdfArgs& a) {
    Plugin& p = a.p;
    Bsdf* b = &a.bsdf;
    auto line_of = [&](const char* n) { return a.b.find(p, n) ? a.b.find(p, n)->line : a.tex.at(n).line; };
    const bool has_a = a.b.find(p, "alpha") || a.tex.count("alpha"),
               has_u = a.b.find(p, "alphaU") || a.tex.count("alphaU"),
               has_v = a.b.find(p, "alphaV") || a.tex.count("alphaV");
    if (has_a && (has_u || has_v)) fail(*p.src, line_of("alpha"), "give either alpha or alphaU/alphaV");
    if (has_u != has_v) fail(*p.src, line_of(has_u ? "alphaU" : "alphaV"), "alphaU and alphaV must be given together");
    if (has_u) {
        b->alpha_u = alpha_param(a, "alphaU", 0.1f, &b->tex_alpha_u);
        b->alpha_v = alpha_param(a, "alphaV", 0.1f, &b->tex_alpha_v);
    } else {
        b->alpha_u = b->alpha_v = alpha_param(a, "alpha", 0.1f, &b->tex_alpha_u);
        b->tex_alpha_v = b->tex_alpha_u;
    }
}

Microfacet distribution(SceneBuilder& b, Plugin& p) {
    std::string d = lower(b.get_string(p, "distribution", "beckmann"));
    if (d == "beckmann") return Microfacet::Beckmann;
    if (d == "ggx") return Microfacet::GGX;
    const int line = b.find(p, "distribution")->line;
    if (d == "phong" || d == "as")
        fail(*p.src, line, "microfacet distribution " + quote(d) + " is unsupported (beckmann or ggx)");
    fail(*p.src, line, "unknown microfacet distribution " + quote(d) + " (beckmann or ggx)");
}

const char* mitsuba_ignores_it(const std::string&) { return "Mitsuba 0.5 ignores it too (unqueried attribute)"; }
const char* sampling_only(const std::string&) { return "a sampling strategy only; it does not change the result"; }

// Whether some lobe of b passes light through (a Mixture: some part's, looked up in scene.bsdfs).
bool transmits_light(const SceneBuilder& sb, const Bsdf& b) {
    if (b.type == BsdfType::Mixture) {
        for (int i = 0; i < b.part_count; ++i)
            if (transmits_light(sb, sb.scene.bsdfs[b.part_index[i]])) return true;
        return false;
    }
    return b.type == BsdfType::Dielectric || b.type == BsdfType::ThinDielectric || b.type == BsdfType::RoughDielectric;
}

// ---- the plugins ------------------------------------------------------------------------------

// Wraps one BSDF and makes it act alike on both sides.
void twosided(BsdfArgs& a) {
    SceneBuilder& sb = a.b;
    const Plugin& p = a.p;
    const Source& src = *p.src;
    Bsdf& b = a.bsdf;
    if (p.children.size() != 1)
        fail(src, p.line, "twosided needs exactly one nested <bsdf> or <ref> (iris has no separate back-side BSDF)");
    pugi::xml_node c = p.children[0];
    std::string tag = c.name();
    if (tag == "bsdf") {
        std::string nested_id;
        b = sb.parse_bsdf(src, c, &nested_id);
        if (!nested_id.empty()) sb.named_bsdfs[nested_id].used = true;  // used through the wrapper
    } else if (tag == "ref") {
        b = sb.named_bsdf(src, c).bsdf;
    } else {
        fail(src, src.line_of(c), "<" + tag + "> is not allowed inside bsdf \"twosided\"");
    }
    // As in Mitsuba: the wrapper mirrors the front side onto the back, which means nothing for
    // a surface that lets light through (its back side is the other medium's view of it).
    if (transmits_light(sb, b))
        fail(src, p.line, "twosided cannot wrap a BSDF that transmits light (dielectric, thindielectric, roughdielectric)");
    b.two_sided = true;
}

// A displacement texture and one BSDF, nested or referenced, in either order; the BSDF's shading
// normal is then tilted by the texture's gradient (Bsdf::tex_bump, applied by Scene::intersect).
void bumpmap(BsdfArgs& a) {
    SceneBuilder& sb = a.b;
    const Plugin& p = a.p;
    const Source& src = *p.src;
    Bsdf& b = a.bsdf;
    int16_t bump = -1;
    bool have_bsdf = false;
    auto take_bsdf = [&](const Bsdf& nested, int line) {
        if (have_bsdf) fail(src, line, "bumpmap takes exactly one nested <bsdf> or <ref>");
        have_bsdf = true;
        b = nested;
    };
    for (pugi::xml_node c : p.children) {
        const std::string tag = c.name();
        const int line = src.line_of(c);
        if (tag == "texture") {
            if (bump >= 0) fail(src, line, "bumpmap takes exactly one displacement <texture>");
            // As Mitsuba: a height map read with the implicit gamma would be decoded as sRGB colour.
            if (std::string(c.attribute("type").value()) == "bitmap" && !c.find_child_by_attribute("name", "gamma"))
                fail(src, line, "a bitmap used as a bump map needs an explicit gamma (most likely <float name=\"gamma\" value=\"1\"/>)");
            // Mitsuba checks only a bitmap directly inside; one deeper (in a `scale`) is decoded with the
            // file's own curve there too, which iris follows, but says so.
            for (const pugi::xpath_node& x : c.select_nodes(".//texture[@type='bitmap']"))
                if (!x.node().find_child_by_attribute("name", "gamma"))
                    sb.warn(src, src.line_of(x.node()), "height-map bitmap without an explicit gamma: decoded with the file's own "
                                                        "curve (sRGB for 8-bit images), as in Mitsuba; give gamma 1 for linear heights");
            bump = sb.parse_texture(src, c, "displacement texture of bsdf \"bumpmap\"");
        } else if (tag == "bsdf") {
            std::string nested_id;
            take_bsdf(sb.parse_bsdf(src, c, &nested_id), line);
            if (!nested_id.empty()) sb.named_bsdfs[nested_id].used = true;  // used through the wrapper
        } else if (tag == "ref" && sb.named_textures.count(c.attribute("id").value())) {
            if (bump >= 0) fail(src, line, "bumpmap takes exactly one displacement <texture>");
            bump = sb.texture_ref(src, c);
        } else if (tag == "ref") {
            take_bsdf(sb.named_bsdf(src, c).bsdf, line);
        } else {
            fail(src, line, "<" + tag + "> is not allowed inside bsdf \"bumpmap\"");
        }
    }
    if (bump < 0) fail(src, p.line, "bumpmap needs a displacement <texture>");
    if (!have_bsdf) fail(src, p.line, "bumpmap needs a nested <bsdf> or <ref>");
    if (b.tex_bump >= 0) fail(src, p.line, "a bumpmap inside a bumpmap is not supported (iris keeps one per BSDF)");
    b.tex_bump = bump;
}

// Mitsuba's `mask`: a nested BSDF seen with probability `opacity` (a grey spectrum or a texture,
// default 0.5); elsewhere the surface lets rays through unchanged. The result is the nested BSDF with
// Bsdf::opacity / tex_opacity set; Accel's Embree filter does the rest (bsdf.h, DESIGN.md "Masks").
// iris's opacity is one number, so a coloured one is refused (Mitsuba weighs the colour per channel).
// As Mitsuba (ensureEnergyConservation), an opacity above 1 is scaled by 0.99 / its maximum, with a warning.
void mask(BsdfArgs& a) {
    SceneBuilder& sb = a.b;
    Plugin& p = a.p;
    const Source& src = *p.src;
    Bsdf& b = a.bsdf;
    bool have_bsdf = false;
    int16_t tex = -1;
    int tex_line = 0;
    auto take_bsdf = [&](const Bsdf& nested, int line) {
        if (have_bsdf) fail(src, line, "mask takes exactly one nested <bsdf> or <ref> (the BSDF where the surface is opaque)");
        have_bsdf = true;
        b = nested;
    };
    auto take_texture = [&](pugi::xml_node c, int line) {
        const std::string name = c.attribute("name").value();
        if (name != "opacity")
            fail(src, line, "<" + std::string(c.name()) + " name=" + quote(name) + "> inside bsdf \"mask\": only opacity can be a texture");
        if (tex >= 0) fail(src, line, "parameter \"opacity\" given twice (first at line " + std::to_string(tex_line) + ")");
        tex_line = line;
        tex = std::string(c.name()) == "texture" ? sb.parse_texture(src, c, "texture for parameter \"opacity\" of bsdf \"mask\"")
                                                 : sb.texture_ref(src, c);
    };
    for (pugi::xml_node c : p.children) {
        const std::string tag = c.name();
        const int line = src.line_of(c);
        if (tag == "texture") {
            take_texture(c, line);
        } else if (tag == "bsdf") {
            std::string nested_id;
            take_bsdf(sb.parse_bsdf(src, c, &nested_id), line);
            if (!nested_id.empty()) sb.named_bsdfs[nested_id].used = true;  // used through the wrapper
        } else if (tag == "ref" && sb.named_textures.count(c.attribute("id").value())) {
            take_texture(c, line);
        } else if (tag == "ref") {
            take_bsdf(sb.named_bsdf(src, c).bsdf, line);
        } else {
            fail(src, line, "<" + tag + "> is not allowed inside bsdf \"mask\"");
        }
    }
    if (tex >= 0 && sb.find(p, "opacity"))
        fail(src, sb.find(p, "opacity")->line, "parameter \"opacity\" given twice (a texture at line " + std::to_string(tex_line) + ")");
    if (!have_bsdf) fail(src, p.line, "mask needs a nested <bsdf> or <ref> (the BSDF where the surface is opaque)");
    // The largest opacity and whether every value is grey: the constant's, or the texture's texels (a
    // checkerboard's two colours).
    std::vector<RGB> values;
    int line = p.line;
    if (tex >= 0) {
        const Texture& t = sb.scene.textures[size_t(tex)];
        values = t.type == TextureType::Checkerboard ? std::vector<RGB>{t.color0, t.color1} : t.texels;
        line = tex_line;
    } else {
        values = {sb.get_spectrum(p, "opacity", RGB(0.5f))};
        if (Prop* o = sb.find(p, "opacity")) line = o->line;
    }
    float top = 0;
    for (const RGB& v : values) {
        if (!is_finite(v) || v.r < 0 || v.g < 0 || v.b < 0) fail(src, line, "mask: opacity must be finite and non-negative");
        const float hi = std::max({v.r, v.g, v.b}), lo = std::min({v.r, v.g, v.b});
        // Grey within 0.01 (linear units, the opacity's own scale): room for a JPEG's chroma noise or a
        // spectrum's conversion to RGB; the luminance then stands for all channels (an error of <= 0.01).
        if (hi - lo > 0.01f)
            fail(src, line, "mask: a coloured opacity is not supported (iris lets a ray through with one probability for "
                            "all channels; give r = g = b)");
        top = std::max(top, hi);
    }
    float opacity = tex >= 0 ? 1.0f : luminance(values[0]);
    if (top > 1) {
        const float k = 0.99f / top;
        char msg[160];
        std::snprintf(msg, sizeof msg, "mask: opacity reaches %g (> 1): scaled by %g, as Mitsuba's ensureEnergyConservation does",
                      double(top), double(k));
        sb.warn(src, line, msg);
        opacity *= k;
    }
    // A mask inside a mask: opacities multiply, which one factor holds only where both are constants.
    if (b.tex_opacity >= 0 || (bsdf_is_masked(b) && tex >= 0))
        fail(src, p.line, "a mask inside a mask is supported only with constant opacities (iris keeps one opacity texture per BSDF)");
    b.opacity *= opacity;
    b.tex_opacity = tex;
}

// Mitsuba's diffuse and roughdiffuse read `reflectance`, or `diffuseReflectance` where that is absent.
const char* reflectance_name(BsdfArgs& a) {
    return a.b.find(a.p, "reflectance") || a.tex.count("reflectance") ? "reflectance" : "diffuseReflectance";
}

void diffuse(BsdfArgs& a) {
    a.bsdf.type = BsdfType::Diffuse;
    a.bsdf.diffuse = spectrum_param(a, reflectance_name(a), RGB(0.5f), &a.bsdf.tex_diffuse);
}

void roughdiffuse(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    b.type = BsdfType::RoughDiffuse;
    b.diffuse = spectrum_param(a, reflectance_name(a), RGB(0.5f), &b.tex_diffuse);
    b.alpha_u = b.alpha_v = alpha_param(a, "alpha", 0.2f, &b.tex_alpha_u);
    b.tex_alpha_v = b.tex_alpha_u;
    if (a.b.get_bool(a.p, "useFastApprox", false))
        a.b.warn(*a.p.src, a.b.find(a.p, "useFastApprox")->line,
                 "useFastApprox ignored: iris always evaluates the full Oren-Nayar model");
}

// dielectric, thindielectric and roughdielectric.
void dielectric(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    const std::string& t = a.p.type;
    b.type = t == "dielectric"       ? BsdfType::Dielectric
             : t == "thindielectric" ? BsdfType::ThinDielectric
                                     : BsdfType::RoughDielectric;
    b.ior = a.b.get_ior(a.p, "intIOR", "bk7") / a.b.get_ior(a.p, "extIOR", "air");
    b.specular = spectrum_param(a, "specularReflectance", RGB(1.0f), &b.tex_specular);
    b.transmittance = spectrum_param(a, "specularTransmittance", RGB(1.0f), &b.tex_transmittance);
    if (t == "roughdielectric") {
        b.distribution = distribution(a.b, a.p);
        anisotropic_alpha(a);
        // Refraction through an index-matched rough interface goes straight on: a Dirac event
        // the microfacet model has no density for.
        if (std::abs(b.ior - 1.0f) < 1e-4f)
            fail(*a.p.src, a.p.line, "roughdielectric: intIOR equals extIOR (an index-matched interface does not scatter)");
    }
    a.ignore = [](const std::string& param) -> const char* {
        if (param == "diffuseReflectance" || param == "reflectance") return mitsuba_ignores_it(param);
        if (param == "sampleVisible") return sampling_only(param);
        return nullptr;
    };
}

// conductor and roughconductor.
void conductor(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    const bool rough = a.p.type == "roughconductor";
    b.type = rough ? BsdfType::RoughConductor : BsdfType::Conductor;
    const std::string material = a.b.get_string(a.p, "material", "Cu");
    RGB eta, k;
    if (!conductor_ior(material, &eta, &k))
        fail(*a.p.src, a.b.find(a.p, "material")->line, "unknown conductor material " + quote(material));
    eta = a.b.get_spectrum(a.p, "eta", eta);
    k = a.b.get_spectrum(a.p, "k", k);
    const float ext = a.b.get_ior(a.p, "extEta", "air");
    b.eta = eta / ext;
    b.k = k / ext;
    b.specular = spectrum_param(a, "specularReflectance", RGB(1.0f), &b.tex_specular);
    if (rough) {
        b.distribution = distribution(a.b, a.p);
        anisotropic_alpha(a);
    }
    a.ignore = [rough](const std::string& param) -> const char* {
        if (param == "reflectance") return mitsuba_ignores_it(param);
        if (rough && param == "sampleVisible") return sampling_only(param);
        return nullptr;
    };
}

// plastic and roughplastic.
void plastic(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    const bool rough = a.p.type == "roughplastic";
    b.type = rough ? BsdfType::RoughPlastic : BsdfType::Plastic;
    b.ior = a.b.get_ior(a.p, "intIOR", "polypropylene") / a.b.get_ior(a.p, "extIOR", "air");
    b.diffuse = spectrum_param(a, "diffuseReflectance", RGB(0.5f), &b.tex_diffuse);
    b.specular = spectrum_param(a, "specularReflectance", RGB(1.0f), &b.tex_specular);
    b.nonlinear = a.b.get_bool(a.p, "nonlinear", false);
    if (rough) {
        b.distribution = distribution(a.b, a.p);
        b.alpha_u = b.alpha_v = alpha_param(a, "alpha", 0.1f, &b.tex_alpha_u);
        b.tex_alpha_v = b.tex_alpha_u;
        a.ignore = [](const std::string& param) -> const char* {
            return param == "sampleVisible" ? sampling_only(param) : nullptr;
        };
    }
}

void ward(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    b.type = BsdfType::Ward;
    const std::string variant = lower(a.b.get_string(a.p, "variant", "balanced"));
    if (variant == "ward") b.ward_variant = WardVariant::Ward;
    else if (variant == "ward-duer") b.ward_variant = WardVariant::WardDuer;
    else if (variant == "balanced") b.ward_variant = WardVariant::Balanced;
    else fail(*a.p.src, a.b.find(a.p, "variant")->line, "ward variant must be ward, ward-duer or balanced, not " + quote(variant));
    anisotropic_alpha(a);
    b.diffuse = spectrum_param(a, "diffuseReflectance", RGB(0.5f), &b.tex_diffuse);
    b.specular = spectrum_param(a, "specularReflectance", RGB(0.2f), &b.tex_specular);
}

// The largest value per channel a parameter can take: the constant, or its texture's largest texel
// (Mitsuba's Texture::getMaximum).
RGB param_maximum(const SceneBuilder& sb, RGB value, int16_t tex) {
    if (tex < 0) return value;
    const Texture& t = sb.scene.textures[size_t(tex)];
    auto cmax = [](RGB x, RGB y) { return RGB(std::max(x.r, y.r), std::max(x.g, y.g), std::max(x.b, y.b)); };
    if (t.type == TextureType::Checkerboard) return cmax(t.color0, t.color1);
    RGB m(0.0f);
    for (const RGB& v : t.texels) m = cmax(m, v);
    return m;
}
// The parameter times k: the constant scaled, or a texture scaled as Mitsuba's `scale` texture would
// (the same key as textures.cpp's scale, so equal ones are shared).
void scale_param(SceneBuilder& sb, RGB* value, int16_t* tex, float k) {
    if (*tex < 0) {
        *value = *value * k;
        return;
    }
    Texture t = sb.scene.textures[size_t(*tex)];
    for (RGB& v : t.texels) v = v * k;
    t.color0 = t.color0 * k;
    t.color1 = t.color1 * k;
    char key[96];
    std::snprintf(key, sizeof key, "scale|%d|%a|%a|%a", int(*tex), k, k, k);
    *tex = sb.add_texture(std::move(t), key);
}

// Mitsuba 0.5's modified Phong (libcommon/bsdf_phong.cpp). As Mitsuba's BSDF::ensureEnergyConservation
// (on by default): where diffuse and specular reflectance (their largest texels, if textured) sum to more
// than 1 in some channel, both are scaled by 0.99 / that sum, with a warning.
void phong(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    b.type = BsdfType::Phong;
    b.diffuse = spectrum_param(a, "diffuseReflectance", RGB(0.5f), &b.tex_diffuse);
    b.specular = spectrum_param(a, "specularReflectance", RGB(0.2f), &b.tex_specular);
    if (auto it = a.tex.find("exponent"); it != a.tex.end()) {
        it->second.used = true;
        b.tex_alpha_u = b.tex_alpha_v = it->second.index;  // (Bsdf::alpha_u holds the exponent)
        b.alpha_u = b.alpha_v = 30.0f;
    } else {
        b.alpha_u = b.alpha_v = a.b.get_float(a.p, "exponent", 30.0f);
        // Mitsuba takes any number; a negative exponent makes the lobe's normalisation (n + 1) negative
        // or its peak infinite, so iris refuses it.
        if (!(b.alpha_u >= 0) || !std::isfinite(b.alpha_u))
            fail(*a.p.src, a.b.find(a.p, "exponent")->line, "phong: exponent must be finite and non-negative");
    }
    if (a.b.get_bool(a.p, "ensureEnergyConservation", true)) {
        const RGB sum = param_maximum(a.b, b.diffuse, b.tex_diffuse) + param_maximum(a.b, b.specular, b.tex_specular);
        const float peak = std::max({sum.r, sum.g, sum.b});
        if (peak > 1) {
            const float k = 0.99f / peak;
            char msg[200];
            std::snprintf(msg, sizeof msg, "phong: diffuseReflectance + specularReflectance reach %.4g; both scaled by %.4g "
                          "to conserve energy, as Mitsuba does (ensureEnergyConservation=false keeps them)", peak, k);
            a.b.warn(*a.p.src, a.p.line, msg);
            scale_param(a.b, &b.diffuse, &b.tex_diffuse, k);
            scale_param(a.b, &b.specular, &b.tex_specular, k);
        }
    }
}

// The nested <bsdf>s and <ref>s of mixturebsdf/blendbsdf, each added to scene.bsdfs as a part of a.bsdf
// (Bsdf::part_index; Scene::finalize links them). Other nested elements are refused, except a
// <texture>/<ref> named `texture_name` (blendbsdf's weight), whose index goes to *tex.
void read_parts(BsdfArgs& a, const char* texture_name, int16_t* tex) {
    SceneBuilder& sb = a.b;
    const Plugin& p = a.p;
    const Source& src = *p.src;
    Bsdf& b = a.bsdf;
    for (pugi::xml_node c : p.children) {
        const std::string tag = c.name();
        const int line = src.line_of(c);
        const std::string name = c.attribute("name").value();
        if (texture_name && name == texture_name && (tag == "texture" || (tag == "ref" && sb.named_textures.count(c.attribute("id").value())))) {
            if (*tex >= 0) fail(src, line, "parameter " + quote(name) + " given twice");
            *tex = tag == "texture" ? sb.parse_texture(src, c, "texture for parameter " + quote(name) + " of " + p.what())
                                    : sb.texture_ref(src, c);
            continue;
        }
        Bsdf part;
        if (tag == "bsdf") {
            std::string nested_id;
            part = sb.parse_bsdf(src, c, &nested_id);
            if (!nested_id.empty()) sb.named_bsdfs[nested_id].used = true;  // used through the mixture
        } else if (tag == "ref") {
            part = sb.named_bsdf(src, c).bsdf;
        } else {
            fail(src, line, "<" + tag + "> is not allowed inside " + p.what());
        }
        if (b.part_count == kMaxBsdfParts)
            fail(src, line, p.what() + ": iris mixes at most " + std::to_string(kMaxBsdfParts) + " BSDFs");
        // Scene::intersect bumps the hit's frame once, for the BSDF the shape carries.
        if (part.tex_bump >= 0)
            fail(src, line, "a bumpmap inside " + p.what() + " is not supported: put the bumpmap around it");
        // Embree's filter reads the opacity of the BSDF the shape carries.
        if (bsdf_is_masked(part)) fail(src, line, "a mask inside " + p.what() + " is not supported: put the mask around it");
        // BsdfScratch resolves one level of textured parts per hit.
        if (part.type == BsdfType::Mixture && bsdf_has_textured_params(part))
            fail(src, line, "a textured mixturebsdf/blendbsdf inside " + p.what() + " is not supported");
        b.parts_textured = b.parts_textured || bsdf_has_textured_params(part);
        b.part_index[b.part_count++] = sb.add_bsdf(part);
    }
}

// Mitsuba's mixturebsdf: `weights` ("w0, w1, ...", separated by spaces, commas or semicolons), one per
// nested BSDF in document order. As in Mitsuba: a weight that does not parse or is negative, a count
// that differs from the BSDFs', or weights that sum to 0 are errors; with ensureEnergyConservation
// (default true) weights summing to more than 1 are divided by their sum, with a warning.
void mixturebsdf(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    const Source& src = *a.p.src;
    b.type = BsdfType::Mixture;
    const std::optional<std::string> text = a.b.get_string(a.p, "weights");
    const int wline = text ? a.b.find(a.p, "weights")->line : a.p.line;
    std::vector<float> weights;
    std::string token;
    for (size_t i = 0; text && i <= text->size(); ++i) {
        const char ch = i < text->size() ? (*text)[i] : ' ';
        if (ch != ' ' && ch != ',' && ch != ';' && ch != '\t' && ch != '\n') {
            token += ch;
            continue;
        }
        if (token.empty()) continue;
        char* end = nullptr;
        const double w = std::strtod(token.c_str(), &end);
        if (*end != '\0' || !std::isfinite(w)) fail(src, wline, "mixturebsdf: weight " + quote(token) + " is not a number");
        if (w < 0) fail(src, wline, "mixturebsdf: weight " + quote(token) + " is negative");
        weights.push_back(float(w));
        token.clear();
    }
    if (weights.empty()) fail(src, wline, "mixturebsdf needs weights (a string \"w0, w1, ...\", one per nested BSDF)");
    const bool conserve = a.b.get_bool(a.p, "ensureEnergyConservation", true);
    read_parts(a, nullptr, nullptr);
    if (weights.size() != b.part_count)
        fail(src, wline, "mixturebsdf: " + std::to_string(weights.size()) + " weights for " +
                             std::to_string(b.part_count) + " nested BSDFs");
    float sum = 0;
    for (float w : weights) sum += w;
    if (!(sum > 0)) fail(src, wline, "mixturebsdf: the weights must sum to more than 0");
    if (conserve && sum > 1) {
        a.b.warn(src, wline, "mixturebsdf: weights sum to " + std::to_string(sum) + " > 1 and are divided by it, "
                             "as Mitsuba does (ensureEnergyConservation=false keeps them)");
        for (float& w : weights) w /= sum;
    }
    std::copy(weights.begin(), weights.end(), b.part_weight);
}

// Mitsuba's blendbsdf: (1 - weight) times the first nested BSDF plus weight times the second; weight a
// number or a texture (its mean over R, G, B), clamped to [0, 1] as Mitsuba does at every lookup.
void blendbsdf(BsdfArgs& a) {
    Bsdf& b = a.bsdf;
    const Source& src = *a.p.src;
    b.type = BsdfType::Mixture;
    read_parts(a, "weight", &b.tex_blend);
    if (b.part_count != 2) fail(src, a.p.line, "blendbsdf needs exactly two nested BSDFs, not " + std::to_string(b.part_count));
    if (b.tex_blend >= 0 && a.b.find(a.p, "weight"))
        fail(src, a.b.find(a.p, "weight")->line, "parameter \"weight\" given twice");
    float w = 0.5f;  // (a textured weight replaces these per hit)
    if (b.tex_blend < 0) {
        w = a.b.get_float(a.p, "weight", 0.5f);
        if (!std::isfinite(w)) fail(src, a.b.find(a.p, "weight")->line, "blendbsdf: weight must be a finite number");
        if (w < 0 || w > 1) {
            a.b.warn(src, a.b.find(a.p, "weight")->line, "blendbsdf: weight " + std::to_string(w) +
                                                          " is clamped to [0, 1], as Mitsuba does");
            w = std::clamp(w, 0.0f, 1.0f);
        }
    }
    b.part_weight[0] = 1 - w;
    b.part_weight[1] = w;
}

// The BSDF plugins. `wrapper`: the plugin reads its nested elements itself (a wrapped BSDF, a
// bump texture); the others get their nested <texture>s and <ref>s as textured parameters.
struct BsdfPlugin {
    const char* name;
    BsdfBuilder build;
    bool wrapper = false;
};
const BsdfPlugin kBsdfs[] = {
    {"twosided", twosided, true},
    {"bumpmap", bumpmap, true},
    {"mask", mask, true},
    {"diffuse", diffuse},
    {"roughdiffuse", roughdiffuse},
    {"dielectric", dielectric},
    {"thindielectric", dielectric},
    {"roughdielectric", dielectric},
    {"conductor", conductor},
    {"roughconductor", conductor},
    {"plastic", plastic},
    {"roughplastic", plastic},
    {"ward", ward},
    {"phong", phong},
    {"mixturebsdf", mixturebsdf, true},
    {"blendbsdf", blendbsdf, true},
};

void check_bsdf(const Plugin& p, const Bsdf& b) {
    for (const RGB* c : {&b.diffuse, &b.specular, &b.transmittance, &b.eta, &b.k})
        if (!is_finite(*c) || c->r < 0 || c->g < 0 || c->b < 0)
            fail(*p.src, p.line, p.what() + ": colours and IORs must be finite and non-negative");
}

}  // namespace

bool bsdf_type_supported(const std::string& type) {
    for (const BsdfPlugin& k : kBsdfs)
        if (type == k.name) return true;
    return false;
}

// A top-level BSDF only matters through its id (parse_bsdf stores it for later <ref>s).
void SceneBuilder::top_level_bsdf(const Source& src, pugi::xml_node n) {
    std::string id;
    int line = 0;
    parse_bsdf(src, n, &id, &line);
    if (id.empty()) warn(src, line, "a top-level bsdf without an id can never be used");
}

Bsdf SceneBuilder::parse_bsdf(const Source& src, pugi::xml_node n, std::string* id_out, int* line_out) {
    Plugin p = read_plugin(src, n);
    // Name an unsupported BSDF plugin first: wrappers such as mask nest a <bsdf>, which would otherwise
    // be reported as a misplaced element.
    const BsdfPlugin* plugin = nullptr;
    for (const BsdfPlugin& k : kBsdfs)
        if (p.type == k.name) plugin = &k;
    if (!plugin) fail(src, p.line, "unsupported plugin " + quote(p.type) + " (bsdf)");
    Bsdf b;
    IgnoreRule ignore;
    TexParams tex;
    if (!plugin->wrapper) tex = bsdf_textures(*this, p);
    BsdfArgs args{*this, p, tex, b, ignore};
    plugin->build(args);
    for (const auto& [name, tp] : tex)
        if (!tp.used)
            fail(src, tp.line, "parameter " + quote(name) + " of " + p.what() +
                                   (find(p, name) || known_constant_param(name)
                                        ? " cannot be a texture in iris (only reflectances, transmittance and roughness can)"
                                        : " is unknown (a texture was given for it)"));
    finish(p, ignore);
    check_bsdf(p, b);
    if (!p.id.empty()) {
        NamedBsdf nb;
        nb.bsdf = b;
        nb.src = &src;
        nb.line = p.line;
        named_bsdfs[p.id] = nb;
    }
    if (id_out) *id_out = p.id;
    if (line_out) *line_out = p.line;
    return b;
}

NamedBsdf& SceneBuilder::named_bsdf(const Source& src, pugi::xml_node n) {
    check_attrs(src, n, {"id", "name"});
    check_no_text(src, n);
    const int line = src.line_of(n);
    std::string id = attr(src, n, "id");
    if (auto name = opt_attr(src, n, "name"); name && *name != "bsdf")
        fail(src, line, "<ref name=" + quote(*name) + ">: only BSDF references are supported");
    auto it = named_bsdfs.find(id);
    if (it == named_bsdfs.end()) {
        check_not_unbuilt(src, line, id);
        if (const IdInfo* known = id_info(id))
            fail(src, line, "<ref id=" + quote(id) + "> refers to a <" + known->tag + ">, not to a bsdf");
        fail(src, line, "undefined reference " + quote(id) + " (a bsdf must be declared before it is referenced)");
    }
    it->second.used = true;
    return it->second;
}

uint32_t SceneBuilder::add_bsdf(const Bsdf& b) {
    scene.bsdfs.push_back(b);
    return uint32_t(scene.bsdfs.size() - 1);
}

}  // namespace iris::mitsuba
