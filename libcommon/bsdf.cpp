// The Mitsuba 0.5 BSDF plugins the seed scenes use (see bsdf.h for the conventions), following
// Mitsuba 0.5's formulas and sampling strategies so that iris's images match Mitsuba's.
//
// Where iris departs from Mitsuba 0.5, on purpose:
// - Beckmann's Smith G1 is the exact erf form (Mitsuba: a rational fit), and Beckmann visible normals
//   are drawn exactly (microfacet.h); pdf() then equals the sampling density exactly.
// - roughplastic's diffuse attenuation and lobe-selection probability use the smooth Fresnel
//   transmittance 1 - F(cos theta) where Mitsuba interpolates a precomputed table of the rough
//   interface's transmittance T(cos theta, alpha), and its internal diffuse reflectance uses the
//   smooth-interface value fdr_int (a table has no room in the flat Bsdf struct). The two agree as
//   alpha -> 0; measured for Beckmann, eta = 1.5 (single-scattering VNDF estimate of T): alpha = 0.1
//   gives T = 0.909 vs 0.911 at 60 degrees and 0.753 vs 0.747 at 75, but 0.50 vs 0.39 at 85 degrees
//   (alpha = 0.05: 0.42 vs 0.39 at 85). So the approximation is within ~1 % below 75 degrees for the
//   seed scenes' alpha <= 0.1, and underestimates the diffuse base at grazing incidence. The lobe
//   choice only affects variance, never the expected value.
// - Oren-Nayar: Mitsuba's full model can go (slightly) negative for alpha near 1 and back-scattering
//   geometry; we clamp the value at zero.
// - Ward: the half vector is drawn from its slope distribution directly (equivalent to Mitsuba's
//   phi/theta formulas, without their tan/atan quadrant bookkeeping).
#include "libcommon/bsdf.h"
#include "libcommon/mutation.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "libcommon/bsdf_parts.h"
#include "libcommon/microfacet.h"

namespace iris {

namespace {

// Mirror about the shading normal (local frame).
inline Vec3 reflect_normal(Vec3 w) { return {-w.x, -w.y, w.z}; }
// Mirror w about the unit vector m.
inline Vec3 reflect_about(Vec3 w, Vec3 m) { return m * (2.0f * dot(w, m)) - w; }

// Cosine-weighted direction on the +z hemisphere: Shirley-Chiu concentric disk lifted by Malley's
// method. Density per steradian: cos(theta)/pi. (Kept local so that the BSDFs do not depend on
// sampling.cpp's warps.)
inline Vec3 cosine_hemisphere(Vec2 u) {
    float a = 2.0f * u.x - 1.0f, b = 2.0f * u.y - 1.0f;
    if (a == 0 && b == 0) return {0, 0, 1};
    float r, phi;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = (kPi / 4) * (b / a);
    } else {
        r = b;
        phi = kPi / 2 - (kPi / 4) * (a / b);
    }
    float x = r * std::cos(phi), y = r * std::sin(phi);
    return {x, y, safe_sqrt(1.0f - x * x - y * y)};
}
inline float cosine_pdf(Vec3 w) { return w.z > 0 ? w.z * kInvPi : 0.0f; }

// Largest value we let a BSDF return: keeps float overflow (inf, and inf * 0 = NaN downstream) out of
// the renderer for directions within ~1e-19 of the horizon, where some models diverge.
inline float finite_or_max(double v) { return v < double(FLT_MAX) ? float(v) : FLT_MAX; }

// Probability of choosing the specular/glossy lobe in Mitsuba's plastic, roughplastic: the Fresnel
// reflectance F at the incident angle, re-weighted by the specular sampling weight w:
//   F w / (F w + (1 - F)(1 - w)).
inline float plastic_prob_specular(float F, float w) {
    float num = F * w, den = F * w + (1.0f - F) * (1.0f - w);
    return den > 0 ? num / den : 0.0f;
}

// The diffuse base of plastic/roughplastic seen through the coating, without the (1-Fi)(1-Fo) factor:
// Mitsuba's normalisation of the diffuse reflectance by the internal diffuse Fresnel reflectance,
// linear (1 - fdr_int) or per channel (1 - diffuse * fdr_int) with `nonlinear`.
inline RGB plastic_diffuse(const Bsdf& b) {
    if (b.nonlinear) {
        RGB d = b.diffuse;
        for (int c = 0; c < 3; ++c) d[c] = d[c] / std::max(1e-6f, 1.0f - d[c] * b.fdr_int);
        return d;
    }
    return b.diffuse / std::max(1e-6f, 1.0f - b.fdr_int);
}

// ---- Oren-Nayar (Mitsuba roughdiffuse, full model) -------------------------------------------------

// Oren & Nayar 1994, the full qualitative model with the interreflection term, as in Mitsuba's
// roughdiffuse with useFastApprox = false; sigma = alpha / sqrt(2) converts the Beckmann-style RMS
// slope alpha to Oren-Nayar's standard deviation of facet angles (Mitsuba's fit). Returns f cos(theta_o).
RGB oren_nayar_eval(const Bsdf& b, Vec3 wi, Vec3 wo) {
    const float sigma = b.alpha_u * 0.70710678f;
    const float s2 = sigma * sigma;
    const float ci = wi.z, co = wo.z;
    // sin(theta) from x, y (exact near the pole, unlike sqrt(1 - z^2)).
    const float si = std::min(1.0f, std::sqrt(wi.x * wi.x + wi.y * wi.y));
    const float so = std::min(1.0f, std::sqrt(wo.x * wo.x + wo.y * wo.y));
    // cos(phi_i - phi_o); undefined (0) when either direction is at the pole. 1e-4 = Mitsuba's Epsilon.
    float cos_phi = 0;
    if (si > 1e-4f && so > 1e-4f) cos_phi = clamp((wi.x * wo.x + wi.y * wo.y) / (si * so), -1.0f, 1.0f);
    // alpha = the larger polar angle, beta = the smaller (chosen by cosines, as Mitsuba does).
    const bool i_is_beta = ci > co;
    const float theta_i = safe_acos(ci), theta_o = safe_acos(co);
    const float alpha = i_is_beta ? theta_o : theta_i, beta = i_is_beta ? theta_i : theta_o;
    const float sin_alpha = i_is_beta ? so : si, sin_beta = i_is_beta ? si : so;
    const float cos_alpha = i_is_beta ? co : ci, cos_beta = i_is_beta ? ci : co;
    const float tan_beta = sin_beta / cos_beta;  // cos_beta = the larger cosine > 0

    const float tmp = s2 / (s2 + 0.09f);
    const float tmp2 = (4.0f * kInvPi * kInvPi) * alpha * beta;
    const float tmp3 = 2.0f * beta * kInvPi;
    const float C1 = 1.0f - 0.5f * s2 / (s2 + 0.33f);
    float C2 = 0.45f * tmp;
    const float C3 = 0.125f * tmp * tmp2 * tmp2;
    const float C4 = 0.17f * s2 / (s2 + 0.13f);
    C2 *= cos_phi > 0 ? sin_alpha : sin_alpha - tmp3 * tmp3 * tmp3;
    // tan((alpha + beta) / 2) by the half-angle formula.
    const float tan_half = (sin_alpha + sin_beta) / (cos_alpha + cos_beta);

    RGB result;
    for (int c = 0; c < 3; ++c) {
        float rho = b.diffuse[c];
        float single = rho * (C1 + cos_phi * C2 * tan_beta + (1.0f - std::abs(cos_phi)) * C3 * tan_half);
        float dbl = rho * rho * (C4 * (1.0f - cos_phi * tmp3 * tmp3));
        result[c] = std::max(0.0f, (single + dbl) * kInvPi * co);
    }
    return result;
}

// ---- rough conductor ---------------------------------------------------------------------------------

MicrofacetDistribution conductor_distribution(const Bsdf& b) {
    return MicrofacetDistribution(b.distribution, b.alpha_u, b.alpha_v);
}

// Roughplastic is isotropic in Mitsuba 0.5: alpha_u is its alpha.
MicrofacetDistribution plastic_distribution(const Bsdf& b) {
    return MicrofacetDistribution(b.distribution, b.alpha_u, b.alpha_u);
}

// Torrance-Sparrow reflection without the Fresnel/colour factor: D G / (4 cos_i) = f cos_o / F.
float microfacet_reflection(const MicrofacetDistribution& d, Vec3 wi, Vec3 wo, Vec3 h) {
    float D = microfacet_d(d, h);
    if (D == 0) return 0.0f;
    float G = microfacet_g1(d, wi, h) * microfacet_g1(d, wo, h);
    return finite_or_max(double(D) * G / (4.0 * wi.z));
}

// Density per steradian of wo for a reflection off a visible normal sampled from wi:
// D_wi(h) / (4 wo.h) = D(h) G1(wi, h) / (4 cos_i), h the half vector.
float microfacet_reflection_pdf(const MicrofacetDistribution& d, Vec3 wi, Vec3 h) {
    float D = microfacet_d(d, h);
    if (D == 0) return 0.0f;
    return finite_or_max(double(D) * microfacet_g1(d, wi, h) / (4.0 * wi.z));
}

// ---- rough dielectric -------------------------------------------------------------------------------
// Walter et al. 2007 ("Microfacet Models for Refraction through Rough Surfaces"), as Mitsuba 0.5's
// roughdielectric: a microfacet normal m is drawn from the normals visible from wi (on wi's side of the
// surface), then the path reflects off it with the Fresnel probability F(wi.m) or refracts through it.
// Works from either side; eta below is the relative IOR of wo's side over wi's (ior entering, 1/ior
// leaving) for refraction. With h the (generalised) half vector, m = h:
//   reflection    f |cos_o| = R F D G / (4 |cos_i|)
//   refraction    f |cos_o| = T (1 - F) D G |wi.h| |wo.h| / (|cos_i| (wi.h + eta wo.h)^2) * s
// with s = 1 for importance and 1 / eta^2 for radiance (radiance is compressed into the denser medium);
// the densities are the visible normal's density times the Jacobian of wo against m,
//   reflection    F D_wi(h) / (4 |wo.h|),   refraction   (1 - F) D_wi(h) eta^2 |wo.h| / (wi.h + eta wo.h)^2.

MicrofacetDistribution dielectric_distribution(const Bsdf& b) {
    return MicrofacetDistribution(b.distribution, b.alpha_u, b.alpha_v);
}

// The microfacet normal that takes wi to wo (on the upper side, z > 0), and for refraction the relative
// IOR eta; false where no microfacet can (on the horizon, or wo on the wrong side of it).
bool rough_dielectric_half(const Bsdf& b, Vec3 wi, Vec3 wo, Vec3* h, float* eta, bool* reflect) {
    if (wi.z == 0 || wo.z == 0) return false;
    *reflect = wi.z * wo.z > 0;
    *eta = *reflect ? 1.0f : wi.z > 0 ? b.ior : 1.0f / b.ior;
    // In double: D falls steeply in its tails (Beckmann), and (wi, wo) and (wo, wi) must give the same h.
    const double e = *eta;
    double vx = double(wi.x) + e * wo.x, vy = double(wi.y) + e * wo.y, vz = double(wi.z) + e * wo.z;
    const double len = std::sqrt(vx * vx + vy * vy + vz * vz);
    if (!(len > 1e-7)) return false;  // (refraction straight through at eta = 1: not a microfacet event)
    const double sign = vz < 0 ? -1.0 / len : 1.0 / len;
    const Vec3 v(float(vx * sign), float(vy * sign), float(vz * sign));
    *h = v;
    // Both directions must see m from their own side: wi on wi's side of the microsurface, wo on the
    // same side for reflection and the other side for refraction.
    const float di = dot(wi, v), dout = dot(wo, v);
    if (di * wi.z <= 0 || dout * wo.z <= 0) return false;
    return *reflect ? true : di * dout < 0;
}

// F at microfacet h for the pair with cosines di = wi.h, dout = wo.h. For a refraction, from the end outside
// (cosine > 0): the same number whichever end the path starts from, and well conditioned -- where one end
// grazes the microfacet the other is at the critical angle, where cos_t = sqrt(1 - eta^2 sin^2) loses
// every digit of float.
float rough_dielectric_fresnel(const Bsdf& b, float di, float dout) {
    return fresnel_dielectric(di * dout < 0 && dout > 0 ? dout : di, b.ior);
}

RGB rough_dielectric_eval(const Bsdf& b, Vec3 wi, Vec3 wo, TransportMode mode) {
    Vec3 h;
    float eta;
    bool reflect;
    if (!rough_dielectric_half(b, wi, wo, &h, &eta, &reflect)) return RGB(0.0f);
    const MicrofacetDistribution d = dielectric_distribution(b);
    const double D = microfacet_d(d, h);
    if (D == 0) return RGB(0.0f);
    const double G = double(microfacet_g1(d, wi, h)) * microfacet_g1(d, wo, h);
    const float di = dot(wi, h), dout = dot(wo, h);
    const double F = rough_dielectric_fresnel(b, di, dout);
    if (reflect) return b.specular * finite_or_max(F * D * G / (4.0 * std::abs(wi.z)));
    const double denom = double(di) + double(eta) * dout;
    const double scale = mode == TransportMode::Radiance ? 1.0 : double(eta) * eta;
    return b.transmittance *
           finite_or_max((1.0 - F) * D * G * std::abs(double(di) * dout) * scale / (std::abs(wi.z) * denom * denom));
}

// The density of wo given the half vector h of (wi, wo) (rough_dielectric_half).
float rough_dielectric_pdf_at(const Bsdf& b, Vec3 wi, Vec3 wo, Vec3 h, float eta, bool reflect) {
    const MicrofacetDistribution d = dielectric_distribution(b);
    const double D = microfacet_d(d, h);
    if (D == 0) return 0.0f;
    const float di = dot(wi, h), dout = dot(wo, h);
    // The density of m among the normals visible from wi (wi's side): G1(wi, m) |wi.m| D(m) / |cos_i|.
    const double visible = microfacet_g1(d, wi, h) * std::abs(double(di)) * D / std::abs(wi.z);
    const double F = rough_dielectric_fresnel(b, di, dout);
    if (reflect) return finite_or_max(F * visible / (4.0 * std::abs(dout)));
    const double denom = double(di) + double(eta) * dout;
    return finite_or_max((1.0 - F) * visible * double(eta) * eta * std::abs(dout) / (denom * denom));
}

float rough_dielectric_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    Vec3 h;
    float eta;
    bool reflect;
    if (!rough_dielectric_half(b, wi, wo, &h, &eta, &reflect)) return 0.0f;
    return rough_dielectric_pdf_at(b, wi, wo, h, eta, reflect);
}

bool rough_dielectric_sample(const Bsdf& b, Vec3 wi, Vec2 u, float uc, BsdfSample* s, TransportMode mode) {
    if (wi.z == 0) return false;
    const float side = wi.z > 0 ? 1.0f : -1.0f;
    // A normal visible from wi's side: from below, the normals m (z > 0) with -wi.m > 0 are those that -wi
    // (above) sees, with the same density G1 |wi.m| D / |cos_i|.
    const Vec3 m = microfacet_sample_visible(dielectric_distribution(b), wi * side, u);
    float cos_t;
    const float c = dot(wi, m);
    const float F = fresnel_dielectric(c, b.ior, &cos_t);
    const bool reflect_m = uc < F;
    if (reflect_m) {
        s->wo = reflect_about(wi, m);
    } else {
        // Snell about m: e = eta_i / eta_t, wo = (e c + cos_t) m - e wi (cos_t signed: wo leaves on m's far side).
        const float e = c > 0 ? 1.0f / b.ior : b.ior;
        s->wo = normalize(m * (e * c + cos_t) - wi * e);
    }
    // A reflection off m that leaves below the macro surface (or a refraction that stays above) is lost
    // (the single-scattering model's energy loss): pdf() gives such a (wi, wo) the other event's density.
    if (reflect_m != (wi.z * s->wo.z > 0)) return false;
    // The density from (wi, wo) alone (their half vector, not m), as bsdf_pdf computes it, so that MIS
    // sees the same number to the last bit; the weight f |cos_o| / pdf in closed form (D, G1(wi), F and the Jacobian cancel):
    // R G1(wo, h) for reflection, T G1(wo, h) s / eta^2 for refraction.
    Vec3 h;
    float eta;
    bool reflect;
    if (!rough_dielectric_half(b, wi, s->wo, &h, &eta, &reflect)) return false;
    s->pdf = rough_dielectric_pdf_at(b, wi, s->wo, h, eta, reflect);
    if (!(s->pdf > 0)) return false;
    const float g1 = microfacet_g1(dielectric_distribution(b), s->wo, h);
    s->weight = reflect ? b.specular * g1
                        : b.transmittance * (mode == TransportMode::Radiance ? g1 / (eta * eta) : g1);
    s->eta = eta;
    s->delta = false;
    return true;
}

// ---- Ward ----------------------------------------------------------------------------------------------

// The Ward specular term f_s (without cos_o), Mitsuba's three normalisations, in double: the balanced
// form divides by (h.n)^4 of the unnormalised half vector, which underflows float near the horizon.
double ward_specular(const Bsdf& b, Vec3 wi, Vec3 wo) {
    const double ax = std::max(b.alpha_u, kMinMicrofacetAlpha), ay = std::max(b.alpha_v, kMinMicrofacetAlpha);
    const double hx = double(wi.x) + wo.x, hy = double(wi.y) + wo.y, hz = double(wi.z) + wo.z;
    const double e = ((hx / ax) * (hx / ax) + (hy / ay) * (hy / ay)) / (hz * hz);
    if (!(e < 700.0)) return 0.0;  // exp underflow (and 0 * inf when hz -> 0)
    double factor;
    switch (b.ward_variant) {
        case WardVariant::Ward:
            factor = 1.0 / (4.0 * M_PI * ax * ay * std::sqrt(double(wi.z) * wo.z));
            break;
        case WardVariant::WardDuer:
            factor = 1.0 / (4.0 * M_PI * ax * ay * double(wi.z) * wo.z);
            break;
        case WardVariant::Balanced:
        default:
            factor = (hx * hx + hy * hy + hz * hz) / (M_PI * ax * ay * hz * hz * hz * hz);
            break;
    }
    double v = factor * std::exp(-e);
    // Mitsuba drops tiny values: evaluating the sampling density where it is extremely small is
    // numerically fragile, and such values contribute nothing.
    return v > 1e-10 ? v : 0.0;
}

// Density per steradian of wo of the Ward specular sampler: the half vector has the anisotropic
// Beckmann density D(h) cos(theta_h) = exp(-tan^2 theta_h (cos^2 phi/ax^2 + sin^2 phi/ay^2)) /
// (pi ax ay cos^3 theta_h); the reflection Jacobian is 1 / (4 h.wo).
double ward_specular_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    const double ax = std::max(b.alpha_u, kMinMicrofacetAlpha), ay = std::max(b.alpha_v, kMinMicrofacetAlpha);
    double hx = double(wi.x) + wo.x, hy = double(wi.y) + wo.y, hz = double(wi.z) + wo.z;
    const double len = std::sqrt(hx * hx + hy * hy + hz * hz);
    if (!(len > 0)) return 0.0;
    hx /= len, hy /= len, hz /= len;
    const double e = ((hx / ax) * (hx / ax) + (hy / ay) * (hy / ay)) / (hz * hz);
    if (!(e < 700.0)) return 0.0;
    const double h_wo = hx * wo.x + hy * wo.y + hz * wo.z;
    if (h_wo <= 0) return 0.0;
    return std::exp(-e) / (4.0 * M_PI * ax * ay * h_wo * hz * hz * hz);
}

// ---- Dispatch on the front side (after the two-sided flip) ---------------------------------------------

RGB eval_front(const Bsdf& b, Vec3 wi, Vec3 wo, TransportMode mode) {
    switch (b.type) {
        case BsdfType::Dielectric:
        case BsdfType::ThinDielectric:
        case BsdfType::Conductor:
            return RGB(0.0f);  // Dirac lobes only
        case BsdfType::Mixture:
            return detail::mixture_eval(b, wi, wo, mode);
        case BsdfType::RoughDielectric:
            return rough_dielectric_eval(b, wi, wo, mode);  // both sides
        default:
            break;
    }
    // Every remaining model is one-sided reflection: nothing passes through, nothing from below.
    if (wi.z <= 0 || wo.z <= 0) return RGB(0.0f);
    switch (b.type) {
        case BsdfType::Diffuse:
            return b.diffuse * (kInvPi * wo.z);
        case BsdfType::RoughDiffuse:
            return oren_nayar_eval(b, wi, wo);
        case BsdfType::RoughConductor: {
            const Vec3 h = normalize(wi + wo);
            const float m = microfacet_reflection(conductor_distribution(b), wi, wo, h);
            if (m == 0) return RGB(0.0f);
            return b.specular * fresnel_conductor(dot(wi, h), b.eta, b.k) * m;
        }
        case BsdfType::Plastic: {
            const float Fi = fresnel_dielectric(wi.z, b.ior), Fo = fresnel_dielectric(wo.z, b.ior);
            return plastic_diffuse(b) * (b.inv_eta2 * (1.0f - Fi) * (1.0f - Fo) * kInvPi * wo.z);
        }
        case BsdfType::RoughPlastic: {
            const Vec3 h = normalize(wi + wo);
            const float m = microfacet_reflection(plastic_distribution(b), wi, wo, h);
            RGB result = b.specular * (fresnel_dielectric(dot(wi, h), b.ior) * m);
            const float Fi = fresnel_dielectric(wi.z, b.ior), Fo = fresnel_dielectric(wo.z, b.ior);
            result += plastic_diffuse(b) * (b.inv_eta2 * (1.0f - Fi) * (1.0f - Fo) * kInvPi * wo.z);
            return result;
        }
        case BsdfType::Phong:
            return detail::phong_eval(b, wi, wo);
        case BsdfType::Ward: {
            const double spec = ward_specular(b, wi, wo);
            RGB result;
            for (int c = 0; c < 3; ++c)
                result[c] = finite_or_max((b.specular[c] * spec + b.diffuse[c] * double(kInvPi)) * wo.z);
            return result;
        }
        default:
            return RGB(0.0f);
    }
}

float pdf_front(const Bsdf& b, Vec3 wi, Vec3 wo) {
    if (b.type == BsdfType::Mixture) return detail::mixture_pdf(b, wi, wo);
    if (bsdf_is_delta(b)) return 0.0f;
    if (b.type == BsdfType::RoughDielectric) return rough_dielectric_pdf(b, wi, wo);
    if (wi.z <= 0 || wo.z <= 0) return 0.0f;
    switch (b.type) {
        case BsdfType::Diffuse:
        case BsdfType::RoughDiffuse:
            return cosine_pdf(wo);
        case BsdfType::RoughConductor:
            if (IRIS_MUTANT(bsdf_alpha_off)) return microfacet_reflection_pdf(MicrofacetDistribution(b.distribution, b.alpha_u * 1.05f, b.alpha_v * 1.05f), wi, normalize(wi + wo));
            return microfacet_reflection_pdf(conductor_distribution(b), wi, normalize(wi + wo));
        case BsdfType::Plastic: {
            const float p_spec = plastic_prob_specular(fresnel_dielectric(wi.z, b.ior), b.specular_sampling_weight);
            return (1.0f - p_spec) * cosine_pdf(wo);
        }
        case BsdfType::RoughPlastic: {
            const float p_spec = plastic_prob_specular(fresnel_dielectric(wi.z, b.ior), b.specular_sampling_weight);
            float p = (1.0f - p_spec) * cosine_pdf(wo);
            if (p_spec > 0) p += p_spec * microfacet_reflection_pdf(plastic_distribution(b), wi, normalize(wi + wo));
            return p;
        }
        case BsdfType::Phong:
            return detail::phong_pdf(b, wi, wo);
        case BsdfType::Ward: {
            const double w = b.specular_sampling_weight;
            double p = (1.0 - w) * cosine_pdf(wo);
            if (w > 0) p += w * ward_specular_pdf(b, wi, wo);
            return finite_or_max(p);
        }
        default:
            return 0.0f;
    }
}

// Fills s->weight = eval/pdf and s->pdf for a sampled non-delta direction; false when the density is
// zero (the direction cannot be produced, or lies outside the model's support).
bool finish_nondelta(const Bsdf& b, Vec3 wi, BsdfSample* s) {
    s->pdf = pdf_front(b, wi, s->wo);
    if (!(s->pdf > 0)) return false;
    s->weight = eval_front(b, wi, s->wo, TransportMode::Radiance) / s->pdf;  // (reflection only: no eta)
    s->delta = false;
    s->eta = 1.0f;
    return true;
}

bool sample_front(const Bsdf& b, Vec3 wi, Vec2 u, float uc, BsdfSample* s, TransportMode mode) {
    switch (b.type) {
        case BsdfType::Dielectric: {
            // Mitsuba's smooth dielectric: reflect with probability F, refract with 1 - F. Works from
            // either side; cos_t < 0 means the path enters the interior.
            float cos_t;
            const float F = fresnel_dielectric(wi.z, b.ior, &cos_t);
            s->delta = true;
            if (uc < F) {
                s->wo = reflect_normal(wi);
                s->weight = b.specular;  // (F / F) times the reflectance multiplier
                s->pdf = F;
                s->eta = 1.0f;
                return true;
            }
            const bool entering = cos_t < 0;
            // Snell: the tangential component scales by eta_i / eta_t and flips (wo points away).
            const float ratio = entering ? 1.0f / b.ior : b.ior;  // eta_i / eta_t
            s->wo = Vec3(-ratio * wi.x, -ratio * wi.y, cos_t);
            s->pdf = 1.0f - F;
            s->eta = entering ? b.ior : 1.0f / b.ior;
            // Radiance is divided by eta^2 on entering a denser medium (eta = eta_t / eta_i crossed by
            // light travelling wo -> wi, i.e. the ratio above squared); importance is not.
            const float factor = mode == TransportMode::Radiance ? ratio * ratio : 1.0f;
            s->weight = b.transmittance * factor;
            return true;
        }
        case BsdfType::ThinDielectric: {
            // Mitsuba's thindielectric: a pane whose two faces are this surface, light bouncing
            // between them any number of times. Reflected in all: R' = R + T R T + T R^3 T + ... =
            // R + T^2 R / (1 - R^2), with R the Fresnel reflectance of one face and T = 1 - R; the
            // rest, 1 - R', leaves the far face parallel to where it came in (the two refractions
            // cancel), so the ray goes straight on and radiance is not rescaled. The same from
            // either side.
            float R = fresnel_dielectric(std::abs(wi.z), b.ior);
            if (R < 1) R += (1 - R) * (1 - R) * R / (1 - R * R);
            s->delta = true;
            s->eta = 1.0f;
            if (uc < R) {
                s->wo = reflect_normal(wi);
                s->weight = b.specular;  // (R' / R') times the reflectance multiplier
                s->pdf = R;
            } else {
                s->wo = -wi;
                s->weight = b.transmittance;
                s->pdf = 1 - R;
            }
            return true;
        }
        case BsdfType::RoughDielectric:
            return rough_dielectric_sample(b, wi, u, uc, s, mode);
        case BsdfType::Mixture:
            return detail::mixture_sample(b, wi, u, uc, s, mode);
        case BsdfType::Conductor: {
            if (wi.z <= 0) return false;
            s->wo = reflect_normal(wi);
            s->weight = b.specular * fresnel_conductor(wi.z, b.eta, b.k);
            s->pdf = 1.0f;
            s->eta = 1.0f;
            s->delta = true;
            return true;
        }
        default:
            break;
    }
    if (wi.z <= 0) return false;
    switch (b.type) {
        case BsdfType::Diffuse:
            s->wo = cosine_hemisphere(u);
            if (s->wo.z <= 0) return false;
            s->pdf = cosine_pdf(s->wo);
            s->weight = b.diffuse;  // (rho cos/pi) / (cos/pi)
            s->eta = 1.0f;
            s->delta = false;
            return true;
        case BsdfType::RoughDiffuse:
            s->wo = cosine_hemisphere(u);
            return finish_nondelta(b, wi, s);
        case BsdfType::RoughConductor: {
            const MicrofacetDistribution d = conductor_distribution(b);
            const Vec3 m = microfacet_sample_visible(d, wi, u);
            s->wo = reflect_about(wi, m);
            if (s->wo.z <= 0) return false;
            // Recompute from the half vector of (wi, wo) rather than m, so that pdf and weight equal
            // bsdf_pdf/bsdf_eval for this pair to the last bit (MIS relies on it). With separable
            // Smith G the weight is F G1(wo): D and G1(wi) cancel.
            const Vec3 h = normalize(wi + s->wo);
            s->pdf = microfacet_reflection_pdf(d, wi, h);
            if (!(s->pdf > 0)) return false;
            s->weight = b.specular * fresnel_conductor(dot(wi, h), b.eta, b.k) * microfacet_g1(d, s->wo, h);
            s->eta = 1.0f;
            s->delta = false;
            return true;
        }
        case BsdfType::Plastic: {
            const float Fi = fresnel_dielectric(wi.z, b.ior);
            const float p_spec = plastic_prob_specular(Fi, b.specular_sampling_weight);
            if (uc < p_spec) {
                s->wo = reflect_normal(wi);
                s->weight = b.specular * (Fi / p_spec);
                s->pdf = p_spec;
                s->eta = 1.0f;
                s->delta = true;
                return true;
            }
            s->wo = cosine_hemisphere(u);
            return finish_nondelta(b, wi, s);
        }
        case BsdfType::RoughPlastic: {
            const float p_spec = plastic_prob_specular(fresnel_dielectric(wi.z, b.ior), b.specular_sampling_weight);
            if (uc < p_spec) {
                s->wo = reflect_about(wi, microfacet_sample_visible(plastic_distribution(b), wi, u));
                if (s->wo.z <= 0) return false;
            } else {
                s->wo = cosine_hemisphere(u);
            }
            return finish_nondelta(b, wi, s);
        }
        case BsdfType::Phong:  // (the diffuse part: diffuse's own warp, so that guiding's u maps alike)
            s->wo = cosine_hemisphere(u);
            if (uc < b.specular_sampling_weight && !detail::phong_sample_lobe(b, wi, u, &s->wo)) return false;
            return finish_nondelta(b, wi, s);
        case BsdfType::Ward: {
            if (uc < b.specular_sampling_weight) {
                // Half vector from the anisotropic Beckmann slope distribution: slopes (x, y) Gaussian
                // with variances ax^2/2, ay^2/2 (Ward 1992's phi_h = atan(ay/ax tan 2 pi u),
                // tan^2 theta_h = -log u / (cos^2 phi/ax^2 + sin^2 phi/ay^2), in Cartesian form).
                const float ax = std::max(b.alpha_u, kMinMicrofacetAlpha);
                const float ay = std::max(b.alpha_v, kMinMicrofacetAlpha);
                const float r = std::sqrt(-std::log(1.0f - u.x));  // 1 - u.x in (0, 1]
                const float phi = 2.0f * kPi * u.y;
                const Vec3 h = normalize(Vec3(r * ax * std::cos(phi), r * ay * std::sin(phi), 1.0f));
                s->wo = reflect_about(wi, h);
                if (s->wo.z <= 0) return false;
            } else {
                s->wo = cosine_hemisphere(u);
            }
            return finish_nondelta(b, wi, s);
        }
        default:
            return false;
    }
}

// Hemispherical average 2 int_0^1 F(mu) mu dmu = int_0^1 F(sqrt(xi)) dxi of the dielectric Fresnel
// reflectance for light arriving from the side where the relative IOR is eta, in double precision.
double diffuse_fresnel_integral(double eta) {
    if (eta == 1.0) return 0.0;
    // For eta < 1, cos^2 < 1 - eta^2 is totally reflected (F = 1): that part integrates to xc exactly.
    const double xc = eta < 1.0 ? 1.0 - eta * eta : 0.0;
    // On [xc, 1] substitute xi = xc + (1 - xc) t^2: F has a square-root edge at xc (and at the horizon
    // for eta > 1) that the substitution makes smooth, so composite Simpson converges at its full rate.
    auto fresnel_d = [eta](double ci) {
        double st2 = (1.0 - ci * ci) / (eta * eta);
        if (st2 >= 1.0) return 1.0;
        double ct = std::sqrt(1.0 - st2);
        double rs = (ci - eta * ct) / (ci + eta * ct), rp = (eta * ci - ct) / (eta * ci + ct);
        return 0.5 * (rs * rs + rp * rp);
    };
    auto integrand = [&](double t) {
        double xi = xc + (1.0 - xc) * t * t;
        return fresnel_d(std::sqrt(xi)) * 2.0 * (1.0 - xc) * t;
    };
    const int n = 2048;  // even
    double sum = integrand(0.0) + integrand(1.0);
    for (int i = 1; i < n; ++i) sum += integrand(double(i) / n) * (i % 2 ? 4.0 : 2.0);
    return xc + sum / (3.0 * n);
}

// Probability of bsdf_sample's coat lobe at wi (front side), for the BSDFs with a diffuse lobe beside it.
float coat_share(const Bsdf& b, Vec3 wi) {
    switch (b.type) {
        case BsdfType::Plastic:
        case BsdfType::RoughPlastic:
            return plastic_prob_specular(fresnel_dielectric(wi.z, b.ior), b.specular_sampling_weight);
        case BsdfType::Ward:
        case BsdfType::Phong: return b.specular_sampling_weight < 1 ? b.specular_sampling_weight : 0.0f;
        default: return 0.0f;
    }
}
// Whether the replaceable part is the cosine lobe (layered BSDFs) rather than the whole BSDF.
bool layered(const Bsdf& b) {
    return b.type == BsdfType::Plastic || b.type == BsdfType::RoughPlastic ||
           ((b.type == BsdfType::Ward || b.type == BsdfType::Phong) && b.specular_sampling_weight < 1);
}

}  // namespace

// ---- Public API -------------------------------------------------------------------------------------------

void bsdf_refresh_weights(Bsdf& b) {
    // Mitsuba: the share of samples sent to the specular lobe is the specular reflectance's luminance
    // over the sum of both lobes' luminances (plastic, roughplastic, ward). For textured reflectances
    // Mitsuba takes the textures' averages, one weight per BSDF; iris takes the values at the hit
    // (scene_bsdf_at), which sends no samples to a lobe that is black at this texel. Either choice is
    // unbiased: eval, pdf and sample of one vertex all see the same weight.
    const float ls = luminance(b.specular), ld = luminance(b.diffuse);
    b.specular_sampling_weight = ls + ld > 0 ? ls / (ls + ld) : 0.5f;
}

void bsdf_prepare(Bsdf& b) {
    bsdf_refresh_weights(b);
    b.textured = bsdf_has_textures(b);
    b.textured_params = bsdf_has_textured_params(b);
    b.inv_eta2 = b.ior > 0 ? 1.0f / (b.ior * b.ior) : 1.0f;
    b.fdr_int = 0.0f;
    if ((b.type == BsdfType::Plastic || b.type == BsdfType::RoughPlastic) && b.ior > 0)
        b.fdr_int = fresnel_diffuse_reflectance(1.0f / b.ior);
}

RGB bsdf_eval(const Bsdf& b, Vec3 wi, Vec3 wo, TransportMode mode) {
    // twosided: the back side is the mirror image of the front (Mitsuba flips the z components).
    if (b.two_sided && wi.z < 0) {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    return eval_front(b, wi, wo, mode);
}

float bsdf_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    if (b.two_sided && wi.z < 0) {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    return pdf_front(b, wi, wo);
}

float bsdf_guidable_share(const Bsdf& b, Vec3 wi) {
    if (b.type == BsdfType::Mixture) {  // (each part folds its own twosided; the mixture's first)
        if (b.two_sided && wi.z < 0) wi.z = -wi.z;
        return detail::mixture_guidable_share(b, wi);
    }
    // A cache's map covers one hemisphere: it cannot stand in for a lobe that also refracts.
    if (bsdf_is_delta(b) || bsdf_transmits(b)) return 0.0f;
    if (b.two_sided && wi.z < 0) wi.z = -wi.z;
    return 1.0f - coat_share(b, wi);
}

float bsdf_guidable_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    if (b.two_sided && wi.z < 0) {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if (b.type == BsdfType::Mixture) return detail::mixture_guidable_pdf(b, wi, wo);
    if (bsdf_transmits(b)) return 0.0f;
    if (!layered(b)) return pdf_front(b, wi, wo);
    if (wi.z <= 0 || wo.z <= 0) return 0.0f;
    return (1.0f - coat_share(b, wi)) * cosine_pdf(wo);
}

bool bsdf_sample(const Bsdf& b, Vec3 wi, Vec2 u, float uc, BsdfSample* s, TransportMode mode) {
    const bool flip = b.two_sided && wi.z < 0;
    if (flip) wi.z = -wi.z;
    if (!sample_front(b, wi, u, uc, s, mode)) return false;
    if (flip) s->wo.z = -s->wo.z;
    return true;
}

bool bsdf_is_delta(const Bsdf& b) {
    if (b.type == BsdfType::Mixture) return b.mix_delta;
    return b.type == BsdfType::Dielectric || b.type == BsdfType::ThinDielectric || b.type == BsdfType::Conductor;
}

bool bsdf_has_delta_lobe(const Bsdf& b) {
    return bsdf_is_delta(b) || b.type == BsdfType::Plastic || (b.type == BsdfType::Mixture && b.mix_has_delta);
}

// Mitsuba 0.5's plastic computes its diffuse Fresnel reflectances with fresnelDiffuseReflectance(eta,
// fast = false), i.e. by numerical integration, not with the published fits (d'Eon & Irving 2011 for
// eta > 1, Egan & Hilgeman 1973 for eta < 1, its "fast" mode, 0.1-0.6 % off for common IORs); we
// integrate too (diffuse_fresnel_integral, ~1e-10 accurate). Exactness matters here: it is what makes
// a white plastic conserve energy exactly, since 1 - fdr(1/eta) = (1 - fdr(eta)) / eta^2.
float fresnel_diffuse_reflectance(float eta) {
    if (!(eta > 0)) return 0.0f;
    return float(diffuse_fresnel_integral(eta));
}

}  // namespace iris
