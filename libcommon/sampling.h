// Warps from the unit square to common domains, each a trio (STYLE.md habit 4):
//   sample_x(u)   -> a point/direction,
//   x_pdf(...)    -> its density (the measure is stated on each function),
//   invert_x(...) -> the u that sample_x maps to the given point (where cheap).
// Plus a discrete distribution (tabulated CDF) for choosing lights, triangles, texels.
#pragma once

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
// PDF per steradian: 1/(2 pi (1 - cos_max)).
Vec3 sample_uniform_cone(Vec2 u, float cos_max);
float uniform_cone_pdf(float cos_max);
Vec2 invert_uniform_cone(Vec3 w, float cos_max);

// Uniform point on a triangle as barycentrics (b1, b2); b0 = 1 - b1 - b2 (Heitz 2019's area-preserving
// square-to-triangle map, which has no sqrt and an exact inverse). PDF per unit area: 1/area.
Vec2 sample_uniform_triangle(Vec2 u);
Vec2 invert_uniform_triangle(Vec2 b);

// Piecewise-constant discrete distribution over n items with non-negative weights.
// sample() returns an index with probability weight[i]/sum and rescales u for reuse.
class Distribution1D {
public:
    Distribution1D() = default;
    explicit Distribution1D(const std::vector<float>& weights);
    // Index with probability pmf(i); `u_remapped` (if given) receives u rescaled to [0,1) inside the bin.
    uint32_t sample(float u, float* u_remapped = nullptr) const;
    float pmf(uint32_t i) const { return func_.empty() || total_ <= 0 ? 0.0f : float(func_[i] / total_); }
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
