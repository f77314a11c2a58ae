// Warps from the unit square and the discrete distribution (see sampling.h for the measures).
//
// Precision notes, kept next to the code that depends on them:
// - Near the +z pole, 1 - z of a float unit vector is quantised to ULP(1) = 6e-8, so every inverse
//   derives 1 - z from x^2 + y^2 instead (one_minus_cos_theta), and every forward map derives
//   sin(theta) from 1 - cos(theta) carried separately (sin^2 = t (2 - t) with t = 1 - cos), never
//   from sqrt(1 - cos^2) of a rounded cosine.
// - Every inverse returns u in [0, 1) (kOneMinusEpsilon is the largest float below 1), matching the
//   domain of the forward maps, so that inverses can be fed straight back into sample_*.
#include "libcommon/sampling.h"
#include "libcommon/mutation.h"

#include "libcommon/rng.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace iris {

namespace {

constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// Clamp to the half-open unit interval the forward maps take (NaN -> 0, so that a bad input can never
// index past a table or into a zero-weight bin).
inline float clamp_unit(float u) { return u >= 0.0f ? std::min(u, kOneMinusEpsilon) : 0.0f; }

// Azimuth of (x, y) as a fraction of a full turn, in [0, 1); 0 for the origin (poles).
inline float azimuth_fraction(float x, float y) {
    float phi = std::atan2(y, x) * kInv2Pi;  // in [-1/2, 1/2]
    if (phi < 0) phi += 1.0f;
    return clamp_unit(phi);
}

// Direction with polar angle given by t = 1 - cos(theta) (in [0, 2]) and azimuth 2 pi u.
inline Vec3 direction_from_one_minus_cos(float t, float u) {
    float sin_theta = safe_sqrt(t * (2.0f - t));
    float phi = 2.0f * kPi * u;
    return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), 1.0f - t};
}

}  // namespace

// ---- sphere and hemisphere -------------------------------------------------------------------------

Vec3 sample_uniform_sphere(Vec2 u) {
    // z = 1 - 2 u0 (Archimedes: uniform in z is uniform in area); 1 - cos = 2 u0.
    return direction_from_one_minus_cos(2.0f * u.x, u.y);
}

Vec2 invert_uniform_sphere(Vec3 w) {
    return {clamp_unit(0.5f * one_minus_cos_theta(w)), azimuth_fraction(w.x, w.y)};
}

Vec3 sample_uniform_hemisphere(Vec2 u) {
    // z = u0 (uniform in z over [0, 1)), so u0 = 0 is the horizon and u0 -> 1 the pole. sin(theta)
    // from (1 - z)(1 + z), exact near the pole (Sterbenz) and near the horizon alike.
    float z = u.x;
    float sin_theta = safe_sqrt((1.0f - z) * (1.0f + z));
    float phi = 2.0f * kPi * u.y;
    return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), z};
}

Vec2 invert_uniform_hemisphere(Vec3 w) { return {clamp_unit(w.z), azimuth_fraction(w.x, w.y)}; }

// ---- concentric disk and cosine hemisphere ---------------------------------------------------------

Vec2 sample_concentric_disk(Vec2 u) {
    // Shirley & Chiu 1997: squares [-1,1]^2 around the origin map to circles, wedges to sectors.
    float a = 2.0f * u.x - 1.0f, b = 2.0f * u.y - 1.0f;
    if (a == 0 && b == 0) return {0, 0};
    float r, phi;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = (kPi / 4) * (b / a);  // in [-pi/4, pi/4], mirrored through the origin when a < 0
    } else {
        r = b;
        phi = (kPi / 2) - (kPi / 4) * (a / b);
    }
    return {r * std::cos(phi), r * std::sin(phi)};
}

Vec2 invert_concentric_disk(Vec2 p) {
    // Undo the wedge the forward map used: |a| > |b| there exactly when |x| > |y| here.
    float radius = std::sqrt(p.x * p.x + p.y * p.y);
    if (radius == 0) return {0.5f, 0.5f};
    float a, b;
    if (std::abs(p.x) > std::abs(p.y)) {
        a = std::copysign(radius, p.x);  // r = a carries the sign of x (cos(phi) > 0)
        b = a * std::atan(p.y / p.x) * (4 / kPi);
    } else {
        b = std::copysign(radius, p.y);  // r = b carries the sign of y (sin(phi) > 0)
        a = b * std::atan(p.x / p.y) * (4 / kPi);
    }
    return {clamp_unit(0.5f * (a + 1.0f)), clamp_unit(0.5f * (b + 1.0f))};
}

Vec3 sample_cosine_hemisphere(Vec2 u) {
    // Malley's method: uniform on the disk, lifted to the hemisphere, is cosine-distributed.
    // At the rim of the disk (u0 or u1 = 0) z is 0 and so is the pdf: callers treat pdf 0 as "no sample".
    Vec2 d = sample_concentric_disk(u);
    if (IRIS_MUTANT(cosine_warp_squeezed)) d = {d.x * 0.97f, d.y * 0.97f};
    return {d.x, d.y, safe_sqrt(1.0f - d.x * d.x - d.y * d.y)};
}

Vec2 invert_cosine_hemisphere(Vec3 w) { return invert_concentric_disk({w.x, w.y}); }

// ---- cone ------------------------------------------------------------------------------------------

Vec3 sample_uniform_cone(Vec2 u, OneMinusCos omc) {
    // Uniform in cos(theta) over [cos_max, 1]: 1 - cos(theta) = u0 (1 - cos_max).
    float m = clamp(omc.value, 0.0f, 2.0f);
    return direction_from_one_minus_cos(u.x * m, u.y);
}

float uniform_cone_pdf(OneMinusCos omc) {
    if (!(omc.value > 0)) return 0.0f;  // degenerate cone: a delta, no density
    return kInv2Pi / std::min(omc.value, 2.0f);
}

Vec2 invert_uniform_cone(Vec3 w, OneMinusCos omc) {
    float m = clamp(omc.value, 0.0f, 2.0f);
    float u0 = m > 0 ? one_minus_cos_theta(w) / m : 0.0f;
    return {clamp_unit(u0), azimuth_fraction(w.x, w.y)};
}

Vec3 sample_uniform_cone(Vec2 u, float cos_max) { return sample_uniform_cone(u, OneMinusCos{1.0f - cos_max}); }
float uniform_cone_pdf(float cos_max) { return uniform_cone_pdf(OneMinusCos{1.0f - cos_max}); }
Vec2 invert_uniform_cone(Vec3 w, float cos_max) { return invert_uniform_cone(w, OneMinusCos{1.0f - cos_max}); }

// ---- triangle --------------------------------------------------------------------------------------

Vec2 sample_uniform_triangle(Vec2 u) {
    // Heitz 2019, "A Low-Distortion Map Between Triangle and Square": the square is split along its
    // diagonal and each half is sheared onto the triangle; both pieces keep area (Jacobian 1/2), so
    // the map is uniform. Returns (b1, b2).
    float b1, b2;
    if (u.x < u.y) {
        b1 = 0.5f * u.x;
        b2 = u.y - b1;
    } else {
        b2 = 0.5f * u.y;
        b1 = u.x - b2;
    }
    return {b1, b2};
}

Vec2 invert_uniform_triangle(Vec2 b) {
    // The branch is recovered from which barycentric is larger: u0 < u1 <=> b1 < b2.
    if (b.x < b.y) return {clamp_unit(2.0f * b.x), clamp_unit(b.y + b.x)};
    return {clamp_unit(b.x + b.y), clamp_unit(2.0f * b.y)};
}

// ---- Distribution1D --------------------------------------------------------------------------------

Distribution1D::Distribution1D(const std::vector<float>& weights) {
    const size_t n = weights.size();
    func_.resize(n);
    cdf_.assign(n + 1, 0.0);
    // Prefix sums in double: with a million texels or triangles a float CDF would lose whole bins.
    double sum = 0;
    size_t last_positive = n;
    for (size_t i = 0; i < n; ++i) {
        float w = weights[i];
        if (!(w >= 0) || !std::isfinite(w))
            throw std::invalid_argument("Distribution1D: weight " + std::to_string(i) + " is " +
                                        std::to_string(w) + " (must be finite and >= 0)");
        func_[i] = w;
        sum += w;
        cdf_[i + 1] = sum;
        if (w > 0) last_positive = i;
    }
    total_ = sum;
    if (total_ <= 0) {
        // Empty: keep func_ (pmf() reports 0 everywhere) and a flat CDF.
        std::fill(cdf_.begin(), cdf_.end(), 0.0);
        return;
    }
    for (size_t i = 1; i <= n; ++i) cdf_[i] /= total_;
    // The CDF must reach exactly 1 at the last positive bin: otherwise rounding leaves a sliver of
    // [0,1) above it that trailing zero-weight bins would capture.
    for (size_t i = last_positive + 1; i <= n; ++i) cdf_[i] = 1.0;
}

uint32_t Distribution1D::sample(float u, float* u_remapped) const {
    if (empty()) {
        if (u_remapped) *u_remapped = clamp_unit(u);
        return 0;
    }
    double x = double(clamp_unit(u));
    // First CDF entry > x, minus one: the bin i with cdf[i] <= x < cdf[i+1]. Such a bin has
    // cdf[i+1] > cdf[i], i.e. positive weight, so zero-weight bins are never returned.
    auto it = std::upper_bound(cdf_.begin(), cdf_.end(), x);
    size_t i = size_t(it - cdf_.begin());
    i = i == 0 ? 0 : i - 1;
    i = std::min(i, func_.size() - 1);
    if (u_remapped) {
        double width = cdf_[i + 1] - cdf_[i];
        double r = width > 0 ? (x - cdf_[i]) / width : 0.0;
        // The float conversion may round up to 1: keep the documented half-open range.
        *u_remapped = clamp_unit(float(r));
    }
    return uint32_t(i);
}

namespace {

inline uint32_t reverse_bits(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

// Nested uniform scramble of a 32-bit fraction (its most significant bit is the first digit): each
// digit is flipped by a hash of the seed and the digits above it only. On the reversed bits that is a
// function in which every output bit depends on the bits below it, which additions and multiplications
// by even constants are (Laine-Karras; constants from Burley 2020's improved version).
inline uint32_t nested_uniform_scramble(uint32_t x, uint32_t seed) {
    x = reverse_bits(x);
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return reverse_bits(x);
}

// Sobol dimension 1 of an index whose bits other than byte b are zero: kSobol1[b][byte].
struct Sobol1Tables {
    uint32_t t[4][256];
    constexpr Sobol1Tables() : t{} {
        uint32_t col[32] = {};  // column k of the generator matrix: v_0 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1)
        for (uint32_t k = 0, v = 1u << 31; k < 32; ++k, v ^= v >> 1) col[k] = v;
        for (int b = 0; b < 4; ++b)
            for (uint32_t byte = 0; byte < 256; ++byte) {
                uint32_t r = 0;
                for (int j = 0; j < 8; ++j)
                    if (byte & (1u << j)) r ^= col[8 * b + j];
                t[b][byte] = r;
            }
    }
    const uint32_t* operator[](int b) const { return t[b]; }
};
constexpr Sobol1Tables kSobol1;

}  // namespace

Vec2 owen_sobol_2d(uint32_t index, uint64_t scramble) {
    // The index shuffled first (Burley 2020): a nested scramble of the index as a fraction leaves its
    // unused high bits a constant C for all indices below 2^k and permutes the low k bits, so the first
    // 2^k samples are Sobol points C 2^k .. C 2^k + 2^k - 1, an aligned block and therefore a net too;
    // and two sequences with different scrambles are no longer paired digit by digit (without it, the
    // coarsest digits of every sequence's point s were the same function of s: the pixel position and
    // the first bounce's direction moved together, and each pixel's estimate had an error its sample
    // variance did not show).
    index = nested_uniform_scramble(index, uint32_t(mix64(scramble)));
    // Dimension 0: the identity generator matrix (the radical inverse); dimension 1: Pascal's triangle
    // mod 2, whose columns are v_k = v_{k-1} ^ (v_{k-1} >> 1) from the top bit.
    // The shuffled index has all 32 bits in use, so dimension 1 is XORed from one table per byte of it
    // (the matrix is linear over GF(2)) instead of a loop over 32 bits: four loads per point.
    const uint32_t d0 = reverse_bits(index);
    const uint32_t d1 = kSobol1[0][index & 0xff] ^ kSobol1[1][(index >> 8) & 0xff] ^ kSobol1[2][(index >> 16) & 0xff] ^
                        kSobol1[3][index >> 24];
    const uint32_t a = nested_uniform_scramble(d0, uint32_t(scramble));
    const uint32_t b = nested_uniform_scramble(d1, uint32_t(scramble >> 32));
    return {float(a >> 8) * 0x1p-24f, float(b >> 8) * 0x1p-24f};
}

}  // namespace iris
