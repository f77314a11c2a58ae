// Fresnel reflectance of a dielectric and of a conductor interface (declared in bsdf.h; moved out of
// bsdf.cpp to keep that file within the size limit).
#include <algorithm>
#include <cmath>

#include "libcommon/bsdf.h"

namespace iris {

float fresnel_dielectric(float cos_i, float eta, float* cos_t) {
    // Mitsuba's fresnelDielectricExt. cos_i > 0: arriving from outside (relative IOR eta);
    // cos_i <= 0: from inside (relative IOR 1/eta).
    if (eta == 1.0f) {
        if (cos_t) *cos_t = -cos_i;
        return 0.0f;
    }
    const bool outside = cos_i > 0;
    const float n = outside ? eta : 1.0f / eta;  // eta_t / eta_i
    // Snell: sin_t = sin_i / n.
    const float cos_t2 = 1.0f - (1.0f - cos_i * cos_i) / (n * n);
    if (cos_t2 <= 0) {  // total internal reflection
        if (cos_t) *cos_t = 0.0f;
        return 1.0f;
    }
    const float ci = std::abs(cos_i), ct = std::sqrt(cos_t2);
    const float rs = (ci - n * ct) / (ci + n * ct);
    const float rp = (n * ci - ct) / (n * ci + ct);
    if (cos_t) *cos_t = outside ? -ct : ct;
    return 0.5f * (rs * rs + rp * rp);
}

// Exact Fresnel reflectance of a conductor (complex IOR eta + i k relative to the outside), unpolarised,
// per channel, by the standard real-arithmetic form (a^2 + b^2 = |n^2 - sin^2|, Born & Wolf):
//   Rs = (a^2+b^2 + c^2 - 2ac) / (a^2+b^2 + c^2 + 2ac),
//   Rp = Rs (c^2 (a^2+b^2) + s^4 - 2acs^2) / (c^2 (a^2+b^2) + s^4 + 2acs^2).
// "No conductor" (Mitsuba's material "none", eta = 0, k = 1) is a perfect mirror: for eta = 0 the
// formula gives exactly 1 whatever k (a purely imaginary or zero index reflects everything); eta <= 0
// is therefore returned as 1 directly, which also covers eta = k = 0 where the formula is 0/0.
RGB fresnel_conductor(float cos_i, RGB eta, RGB k) {
    const double c = clamp(cos_i, 0.0f, 1.0f), c2 = c * c, s2 = 1.0 - c2, s4 = s2 * s2;
    RGB r;
    for (int ch = 0; ch < 3; ++ch) {
        const double e = eta[ch], kk = k[ch];
        if (!(e > 0)) {
            r[ch] = 1.0f;
            continue;
        }
        const double t0 = e * e - kk * kk - s2;
        const double a2b2 = std::sqrt(t0 * t0 + 4.0 * e * e * kk * kk);
        const double a = std::sqrt(std::max(0.0, 0.5 * (a2b2 + t0)));
        const double t1 = a2b2 + c2, t2 = 2.0 * a * c;
        // t1 + t2 = 0 only for eta = 1, k = 0 at grazing: no interface, R = 0 (its limit).
        const double rs = t1 + t2 > 0 ? (t1 - t2) / (t1 + t2) : 0.0;
        const double t3 = a2b2 * c2 + s4, t4 = t2 * s2;
        const double rp = t3 + t4 > 0 ? rs * (t3 - t4) / (t3 + t4) : rs;
        r[ch] = float(clamp(0.5 * (rs + rp), 0.0, 1.0));
    }
    return r;
}

}  // namespace iris
