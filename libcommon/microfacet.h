// Microfacet normal distributions for the rough BSDFs (roughconductor, roughplastic, roughdielectric):
// Beckmann and GGX (Trowbridge-Reitz), anisotropic, with the exact Smith masking function and sampling
// of the distribution of visible normals (VNDF).
//
// Conventions (local shading frame, normal = +z, all vectors unit length):
//   D(m)          density of microfacet normals per steradian of m, normalised so that
//                 integral of D(m) cos(theta_m) over the hemisphere = 1 (projected area).
//   G1(v, m)      Smith masking of direction v by the microsurface, 1 / (1 + Lambda(v)), zero when m
//                 is back-facing as seen from v (Walter et al. 2007's chi+ side test).
//   D_v(m)        visible normals seen from v: G1(v, m) max(0, v.m) D(m) / cos(theta_v), a density per
//                 steradian of m that integrates to one (Heitz 2014).
// Smith G for a pair of directions is the separable product G1(wi) G1(wo), as in Mitsuba 0.5 (not the
// height-correlated form), so that iris matches Mitsuba's images.
//
// Lambda is exact for both distributions: GGX has a closed form, Beckmann the erf form
//   Lambda(a) = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi)),  a = 1/(alpha_v tan theta_v).
// (Mitsuba 0.5 uses a rational fit of this for Beckmann's G1; the exact form is required here because
// the Beckmann VNDF sampler below draws from the exact visible distribution, and pdf() must equal the
// sampling density exactly.)
#pragma once

#include <algorithm>
#include <cmath>

#include "libcommon/bsdf.h"
#include "libcommon/math.h"

namespace iris {

// Roughness below this makes D overflow float and the sampler's arithmetic degenerate; Mitsuba 0.5
// clamps to the same value.
inline constexpr float kMinMicrofacetAlpha = 1e-4f;

struct MicrofacetDistribution {
    Microfacet type = Microfacet::Beckmann;
    float ax = 0.1f, ay = 0.1f;  // alpha along the local x (u) and y (v) axes, >= kMinMicrofacetAlpha

    MicrofacetDistribution() = default;
    MicrofacetDistribution(Microfacet t, float alpha_x, float alpha_y)
        : type(t), ax(std::max(alpha_x, kMinMicrofacetAlpha)), ay(std::max(alpha_y, kMinMicrofacetAlpha)) {}
};

namespace microfacet_detail {

inline constexpr double kSqrtPi = 1.77245385090551602729;

// Inverse error function on (-1, 1) to single precision: Giles 2010 ("Approximating the erfinv
// function", GPU Computing Gems), rational fit in w = -log(1 - x^2).
inline double erfinv_approx(double x) {
    x = std::clamp(x, -1.0 + 1e-15, 1.0 - 1e-15);
    double w = -std::log((1.0 - x) * (1.0 + x)), p;
    if (w < 5.0) {
        w -= 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = std::sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    return p * x;
}

// Inverse error function to double accuracy: erfinv_approx (~1e-7) refined by one Newton step on erf
// (quadratic convergence: ~1e-13).
inline double erfinv(double x) {
    x = std::clamp(x, -1.0 + 1e-15, 1.0 - 1e-15);
    double y = erfinv_approx(x);
    double d = 2.0 / kSqrtPi * std::exp(-y * y);
    if (d > 0) y -= (std::erf(y) - x) / d;
    return y;
}

// alpha^2 tan^2(theta_v) along v's azimuth, i.e. (ax^2 vx^2 + ay^2 vy^2) / vz^2: the one number the
// Smith Lambda of both distributions depends on. +inf for v on the horizon.
inline double alpha2_tan2(const MicrofacetDistribution& d, Vec3 v) {
    double sx = double(d.ax) * v.x, sy = double(d.ay) * v.y, z2 = double(v.z) * v.z;
    double s2 = sx * sx + sy * sy;
    if (s2 == 0) return 0.0;
    if (z2 == 0) return INFINITY;
    return s2 / z2;
}

// Samples the slope (x, y) of a visible microfacet of the isotropic alpha = 1 Beckmann surface, seen
// from a direction at polar angle theta in the xz-plane (azimuth 0). In slope space the visible
// density is proportional to P22(x, y) (cos theta - x sin theta) on x < cot theta, with
// P22 = exp(-x^2 - y^2) / pi (Heitz & d'Eon 2014). It factorises: y is Gaussian with variance 1/2
// (y = erfinv(2 u2 - 1)), and x has density proportional to exp(-x^2) (c - x) on (-inf, c], c = cot
// theta, whose CDF is available in closed form,
//   F(x) = c sqrt(pi)/2 erfc(-x) + exp(-x^2)/2, normalised by F(c) = sqrt(pi) c (1 + Lambda(theta)),
// and is inverted by bracketed Newton iteration in double precision (Jakob 2014 uses the same
// density with a fitted starting point; this version trades a few iterations for exactness).
inline void beckmann_visible_slope11(double cos_t, double sin_t, double u1, double u2, double* sx, double* sy) {
    *sy = erfinv(2.0 * u2 - 1.0);
    // Normal incidence: the weight (c - x) is constant over the Gaussian's support (relative error of
    // this shortcut < 6/c, i.e. < 1e-6 here).
    if (sin_t <= 1e-7 * cos_t) {
        *sx = erfinv(2.0 * u1 - 1.0);
        return;
    }
    const double c = cos_t / sin_t;
    const double half_sqrt_pi = 0.5 * kSqrtPi;
    auto cdf = [&](double x) { return c * half_sqrt_pi * std::erfc(-x) + 0.5 * std::exp(-x * x); };
    const double target = u1 * cdf(c);
    // Bracket: the density is negligible below -6.5 (exp(-42) relative to its peak) and zero above c.
    double lo = -6.5, hi = c;
    // Starting point: exact in both limits of the mixture F is made of, the Gaussian CDF
    // (x = erfinv(2u - 1), c -> inf) and the Rayleigh-like exp(-x^2) part (x = c - sqrt(-log u),
    // c -> 0), blended by the Gaussian part's share of the mass.
    const double w = c * half_sqrt_pi * std::erfc(-c) / cdf(c);
    const double x_gauss = std::min(erfinv_approx(2.0 * u1 - 1.0), c);
    const double x_tail = c - std::sqrt(-std::log(std::max(u1, 1e-300)));
    double x = std::clamp(w * x_gauss + (1.0 - w) * x_tail, lo, hi);
    // Newton on F(x) - target, safeguarded by bisection (F is monotone on the bracket). Stops once the
    // step is below 1e-9: the quadratic convergence has then reached double precision.
    for (int it = 0; it < 64; ++it) {
        const double g = cdf(x) - target;
        if (g > 0)
            hi = x;
        else
            lo = x;
        const double dg = (c - x) * std::exp(-x * x);
        double xn = lo - 1.0;  // (forces bisection where the slope vanishes, at x = c)
        if (dg > 0) {
            xn = x - g / dg;
            if (std::abs(xn - x) <= 1e-9 * (1.0 + std::abs(x))) {
                x = xn;
                break;
            }
        }
        if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
        if (hi - lo <= 1e-12) {
            x = xn;
            break;
        }
        x = xn;
    }
    *sx = x;
}

}  // namespace microfacet_detail

// D(m) per steradian of m; zero for m.z <= 0.
inline float microfacet_d(const MicrofacetDistribution& d, Vec3 m) {
    if (m.z <= 0) return 0.0f;
    const double x = double(m.x) / d.ax, y = double(m.y) / d.ay, z2 = double(m.z) * m.z;
    const double norm = M_PI * double(d.ax) * d.ay;
    if (d.type == Microfacet::Beckmann) {
        // exp(-tan^2 theta (cos^2 phi / ax^2 + sin^2 phi / ay^2)) / (pi ax ay cos^4 theta)
        double e = (x * x + y * y) / z2;
        if (e > 700.0) return 0.0f;  // exp underflows; also keeps 0 * inf out for m near the horizon
        return float(std::exp(-e) / (norm * z2 * z2));
    }
    // GGX: 1 / (pi ax ay (x^2/ax^2 + y^2/ay^2 + z^2)^2), finite everywhere on the hemisphere.
    double t = x * x + y * y + z2;
    return float(1.0 / (norm * t * t));
}

// Smith Lambda(v), >= 0, +inf on the horizon.
inline double microfacet_lambda(const MicrofacetDistribution& d, Vec3 v) {
    double t = microfacet_detail::alpha2_tan2(d, v);
    if (t == 0) return 0.0;
    if (d.type == Microfacet::GGX) {
        if (std::isinf(t)) return INFINITY;
        // (sqrt(1 + t) - 1) / 2, written without cancellation for small t.
        return 0.5 * t / (1.0 + std::sqrt(1.0 + t));
    }
    if (std::isinf(t)) return INFINITY;
    double a = 1.0 / std::sqrt(t);  // = 1 / (alpha tan theta)
    // Lambda < 1e-17 beyond a = 6: the two terms below cancel to rounding noise there.
    if (a > 6.0) return 0.0;
    return 0.5 * (std::exp(-a * a) / (a * microfacet_detail::kSqrtPi) - std::erfc(a));
}

// G1(v, m) = 1 / (1 + Lambda(v)) where m faces v from v's side of the surface, else 0.
inline float microfacet_g1(const MicrofacetDistribution& d, Vec3 v, Vec3 m) {
    if (dot(v, m) * v.z <= 0) return 0.0f;
    double l = microfacet_lambda(d, v);
    return std::isinf(l) ? 0.0f : float(1.0 / (1.0 + l));
}

// Density per steradian of m of the visible normals seen from v (v.z > 0): G1(v,m) max(0,v.m) D(m)/v.z.
inline float microfacet_pdf_visible(const MicrofacetDistribution& d, Vec3 v, Vec3 m) {
    if (v.z <= 0) return 0.0f;
    float dm = dot(v, m);
    if (dm <= 0) return 0.0f;
    return microfacet_g1(d, v, m) * dm * microfacet_d(d, m) / v.z;
}

// Samples a visible normal m seen from v (v.z > 0) with density microfacet_pdf_visible(d, v, m).
//   GGX:      Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (hemisphere construction
//             in the stretched configuration).
//   Beckmann: Heitz & d'Eon 2014 stretch/rotate/unstretch of a visible slope of the alpha = 1
//             surface, drawn exactly by beckmann_visible_slope11.
inline Vec3 microfacet_sample_visible(const MicrofacetDistribution& d, Vec3 v, Vec2 u) {
    if (d.type == Microfacet::GGX) {
        // Stretch v to the alpha = 1 configuration, where visible normals are those of a hemisphere.
        Vec3 vh = normalize(Vec3(d.ax * v.x, d.ay * v.y, v.z));
        float lensq = vh.x * vh.x + vh.y * vh.y;
        Vec3 t1 = lensq > 0 ? Vec3(-vh.y, vh.x, 0) * (1.0f / std::sqrt(lensq)) : Vec3(1, 0, 0);
        Vec3 t2 = cross(vh, t1);
        // Uniform disk point, then warp its lower half onto the projected hemisphere's visible part.
        float r = std::sqrt(u.x), phi = 2.0f * kPi * u.y;
        float p1 = r * std::cos(phi), p2 = r * std::sin(phi);
        float s = 0.5f * (1.0f + vh.z);
        p2 = (1.0f - s) * safe_sqrt(1.0f - p1 * p1) + s * p2;
        Vec3 nh = t1 * p1 + t2 * p2 + vh * safe_sqrt(1.0f - p1 * p1 - p2 * p2);
        // Unstretch (normals transform with the inverse transpose of the stretch).
        Vec3 m(d.ax * nh.x, d.ay * nh.y, std::max(0.0f, nh.z));
        return normalize(m);
    }
    // Beckmann.
    double vx = double(d.ax) * v.x, vy = double(d.ay) * v.y, vz = v.z;
    double len = std::sqrt(vx * vx + vy * vy + vz * vz);
    vx /= len, vy /= len, vz /= len;
    double sin_t = std::sqrt(vx * vx + vy * vy);
    double cos_p = 1, sin_p = 0;
    if (sin_t > 0) cos_p = vx / sin_t, sin_p = vy / sin_t;
    double x, y;
    microfacet_detail::beckmann_visible_slope11(vz, sin_t, u.x, u.y, &x, &y);
    // Rotate the slope to v's azimuth, then unstretch.
    double sx = (cos_p * x - sin_p * y) * d.ax;
    double sy = (sin_p * x + cos_p * y) * d.ay;
    double n = 1.0 / std::sqrt(sx * sx + sy * sy + 1.0);
    return Vec3(float(-sx * n), float(-sy * n), float(n));
}

}  // namespace iris
