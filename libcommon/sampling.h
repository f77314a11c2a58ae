// Warps from the unit square to common domains, each a trio (STYLE.md habit 4):
//   sample_x(u)   -> a point/direction,
//   x_pdf(...)    -> its density (the measure is stated on each function),
//   invert_x(...) -> the u that sample_x maps to the given point (where cheap).
// Plus a discrete distribution (tabulated CDF) for choosing lights, triangles, texels.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "libcommon/math.h"

namespace iris {

// Uniform direction on the unit sphere. PDF per steradian: 1/(4 pi).
Vec3 sample_uniform_sphere(Vec2 u);
inline float uniform_sphere_pdf() { return kInv4Pi; }
Vec2 invert_uniform_sphere(Vec3 w);

// Uniform direction on the +z hemisphere. PDF per steradian: 1/(2 pi).
Vec3 sample_uniform_hemisphere(Vec2 u);
inline float uniform_hemisphere_pdf() { return kInv2Pi; }
Vec2 invert_uniform_hemisphere(Vec3 w);

// Concentric (Shirley-Chiu) map to the unit disk. PDF per unit area: 1/pi.
Vec2 sample_concentric_disk(Vec2 u);
Vec2 invert_concentric_disk(Vec2 p);

// Cosine-weighted direction on the +z hemisphere (Malley's method). PDF per steradian: cos(theta)/pi.
Vec3 sample_cosine_hemisphere(Vec2 u);
inline float cosine_hemisphere_pdf(float cos_theta) { return cos_theta > 0 ? cos_theta * kInvPi : 0.0f; }
Vec2 invert_cosine_hemisphere(Vec3 w);

// Uniform direction inside the cone around +z with cos(half-angle) = cos_max.
// PDF per steradian: 1/(2 pi (1 - cos_max)) inside the cone, 0 outside (the pdf functions return
// the in-cone value; callers know whether their direction is inside). A degenerate cone
// (1 - cos_max <= 0) is a delta with no density: the pdf is then 0 and sample returns +z.
Vec3 sample_uniform_cone(Vec2 u, float cos_max);
float uniform_cone_pdf(float cos_max);
Vec2 invert_uniform_cone(Vec3 w, float cos_max);

// The same cone given by 1 - cos_max instead of cos_max. For narrow cones (a small light far away)
// cos_max is within a few float ULPs of 1, so 1 - cos_max computed from a float cos_max has a large
// relative error (0.0333-radius sphere at 15 units: ~2 %); callers that can compute 1 - cos_max
// accurately (e.g. sin^2/(1 + cos)) pass it here and keep full precision in samples and pdf.
struct OneMinusCos {
    float value;  // 1 - cos(half-angle), in [0, 2]
};
Vec3 sample_uniform_cone(Vec2 u, OneMinusCos omc);
float uniform_cone_pdf(OneMinusCos omc);
Vec2 invert_uniform_cone(Vec3 w, OneMinusCos omc);
// 1 - w.z for a unit vector, accurate near the +z pole (uses x^2 + y^2 = (1 - z)(1 + z) there).
inline float one_minus_cos_theta(Vec3 w) {
    return w.z > 0.5f ? (w.x * w.x + w.y * w.y) / (1.0f + w.z) : 1.0f - w.z;
}

// Uniform point on a triangle as barycentrics (b1, b2); b0 = 1 - b1 - b2 (Heitz 2019's area-preserving
// square-to-triangle map, which has no sqrt and an exact inverse). PDF per unit area: 1/area.
Vec2 sample_uniform_triangle(Vec2 u);
Vec2 invert_uniform_triangle(Vec2 b);

// Point `index` of a 2D Sobol (0,2)-sequence (its first two dimensions: the van der Corput radical
// inverse and the Pascal-matrix dimension), at an index shuffled by a nested scramble and with each
// coordinate Owen-scrambled (nested uniform digit scrambling, Owen 1995, by a hash as Laine and Karras
// 2011 / Burley 2020 describe), all three from `scramble`. For each fixed scramble, the points
// 0 .. 2^k - 1 are a (0,k,2)-net: every elementary interval of area 2^-k (2^a x 2^(k-a) cells) holds
// exactly one, so any prefix of the sequence is stratified at every power of two, as a progressive
// render needs; over random scrambles every single point is uniform on [0,1)^2, so estimates stay
// unbiased, and sequences with different scrambles pair their points at random (Burley's padding).
// Coordinates in [0, 1), 24 bits.
Vec2 owen_sobol_2d(uint32_t index, uint64_t scramble);

// Index of the first element of the sorted a[0..n) greater than x, n if none: std::upper_bound without
// its unpredictable branches (the comparison compiles to a conditional move). A search over a few
// hundred entries costs tens of nanoseconds less: the pixel filter searches twice per camera sample,
// the sphere map once per cache sample. (Distribution1D keeps std::upper_bound: switching it showed
// no measurable gain.)
template <class T>
inline size_t upper_bound_index(const T* a, size_t n, T x) {
    if (n == 0) return 0;
    // Invariant: the answer lies in [lo, lo + len] (len halves each step, the answer n included).
    size_t lo = 0, len = n;
    while (len > 1) {
        const size_t half = len / 2;
        lo = a[lo + half - 1] <= x ? lo + half : lo;
        len -= half;
    }
    return lo + (a[lo] <= x ? 1 : 0);
}

// Piecewise-constant discrete distribution over n items with non-negative weights.
// sample() returns an index with probability weight[i]/sum and rescales u for reuse.
// Weights must be finite and >= 0 (the constructor throws std::invalid_argument otherwise: a NaN
// weight would silently bias every estimate that uses the table). Bins of weight 0 are never
// returned. With no positive weight the distribution is empty(): sample() then returns 0 and callers
// must check empty() first.
class Distribution1D {
public:
    Distribution1D() = default;
    explicit Distribution1D(const std::vector<float>& weights);
    // Index with probability pmf(i) for u in [0,1) (u outside is clamped); `u_remapped` (if given)
    // receives u rescaled to [0,1) inside the chosen bin, uniform and independent of the index.
    uint32_t sample(float u, float* u_remapped = nullptr) const;
    float pmf(uint32_t i) const {
        return i >= func_.size() || total_ <= 0 ? 0.0f : float(func_[i] / total_);
    }
    double total() const { return total_; }
    uint32_t size() const { return uint32_t(func_.size()); }
    bool empty() const { return func_.empty() || total_ <= 0; }

private:
    std::vector<double> func_;  // the weights
    std::vector<double> cdf_;   // size n+1, cdf_[0] = 0, cdf_[n] = 1
    double total_ = 0;
};

// Power heuristic with beta = 2 (Veach 1997), for two strategies with sample counts of one each.
inline float power_heuristic(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    if (a == 0) return 0.0f;
    if (!std::isfinite(a)) return 1.0f;
    return a / (a + b);
}

}  // namespace iris
