// Mitsuba 0.5's `phong`: the modified Phong model (Lafortune & Willems 1994, "Using the modified Phong
// reflectance model for physically based rendering"), a Lambertian base plus a cosine-power lobe about
// the mirror direction, normalised so that the lobe reflects at most its specularReflectance:
//   f(wi, wo) = kd / pi + ks (n + 2) / (2 pi) max(0, cos alpha)^n,   cos alpha = dot(wo, mirror(wi)),
// reflection only, front side only. Sampling: the lobe with probability specular_sampling_weight
// (luminance share of ks, bsdf_refresh_weights), its direction drawn with density
// (n + 1) / (2 pi) cos^n alpha about the mirror direction; else the cosine hemisphere. The exponent n is
// stored in Bsdf::alpha_u (so an exponent texture rides on tex_alpha_u: Mitsuba also reads the
// texture's mean over R, G, B).
#include <cmath>

#include "libcommon/bsdf_parts.h"

namespace iris::detail {

namespace {
inline Vec3 mirror(Vec3 w) { return {-w.x, -w.y, w.z}; }
// Density per steradian of the cosine-power lobe about the mirror direction, and the lobe's value
// without ks: both vanish where cos alpha <= 0.
inline float lobe_pdf(float n, float cos_alpha) {
    return cos_alpha > 0 ? (n + 1) * (0.5f * kInvPi) * std::pow(cos_alpha, n) : 0.0f;
}
}  // namespace

RGB phong_eval(const Bsdf& b, Vec3 wi, Vec3 wo) {
    const float n = b.alpha_u, cos_alpha = dot(wo, mirror(wi));
    RGB result = b.diffuse * kInvPi;
    if (cos_alpha > 0) result += b.specular * ((n + 2) * (0.5f * kInvPi) * std::pow(cos_alpha, n));
    return result * wo.z;
}

float phong_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    const float w = b.specular_sampling_weight;
    return w * lobe_pdf(b.alpha_u, dot(wo, mirror(wi))) + (1 - w) * wo.z * kInvPi;
}

bool phong_sample_lobe(const Bsdf& b, Vec3 wi, Vec2 u, Vec3* wo) {
    // Inverting the lobe's cumulative distribution in cos alpha: cos alpha = u^(1 / (n + 1)).
    const float n = b.alpha_u;
    const float cos_a = std::pow(u.y, 1.0f / (n + 1)), sin_a = safe_sqrt(1 - cos_a * cos_a);
    const float phi = 2 * kPi * u.x;
    *wo = Frame(mirror(wi)).to_world(Vec3(sin_a * std::cos(phi), sin_a * std::sin(phi), cos_a));
    return wo->z > 0;
}

}  // namespace iris::detail
