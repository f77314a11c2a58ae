// How much a cache is worth at a vertex: the probability alpha of BSDF sampling in the one-sample
// mixture alpha p_lobe + (1 - alpha) p_cache (DESIGN.md 4.3) that replaces the BSDF's diffuse lobe
// (the whole BSDF where it has one lobe; a layered BSDF's coat keeps its own share: render's
// integrator), chosen per cache from the cache's
// own distribution instead of one constant for the whole scene (issue 4: "a per-cache BSDF/cache
// selection probability that reflects how useful the cache is").
//
// Model. A cache's map is the photon flux arriving per direction, i.e. proportional to L_i cos(theta):
// the integrand of the reflected radiance of a diffuse surface. Its de-floored, upper-hemisphere part g
// (normalised to integrate to 1) is the ideal sampling density; BSDF sampling of a diffuse surface
// draws the cosine density c = cos(theta)/pi. The one-sample estimator of the integral with the mixture
// has relative variance  V(alpha) = sum_k Omega g_k^2 / (alpha c_k + (1 - alpha) p_k) - 1  over the
// texels k (Omega = 4 pi / N sr each, p = the cache's floored density). alpha is the minimiser of V
// over a grid in [min_alpha, 1]; gain = V(1) / V(alpha) is the predicted variance reduction over plain
// BSDF sampling. A cache whose gain is small does not pay for its lookup and sampling cost: the
// renderer then treats the vertex as unguided (alpha = 1).
//
// The same numbers drive fill-caches' early decision whether a scene needs guiding at all.
#pragma once

#include <vector>

namespace iris {

struct BsdfFractionChoice {
    float alpha = 1.0f;  // probability of BSDF sampling, in [min_alpha, 1]
    float gain = 1.0f;   // predicted variance(alpha = 1) / variance(alpha), >= 1
};

class BsdfFractionChooser {
public:
    // R: map resolution; floor: the atlas's uniform floor weight f (CacheAtlas::floor), in [0, 1).
    BsdfFractionChooser(int resolution, double floor, float min_alpha = 0.1f);
    // pdf_row: the cache's N = R^2 densities per steradian (CacheAtlas::pdf_row).
    BsdfFractionChoice choose(const float* pdf_row) const;

private:
    int N_ = 0;
    float omega_ = 0;             // solid angle of a texel, sr
    float floor_density_ = 0;     // f / (4 pi): the floor's share of every texel's density, per sr
    float unfloor_scale_ = 1;     // 1 / (1 - f)
    std::vector<float> cosine_;   // per texel: mean of cos+(theta)/pi over the texel (0 below the horizon)
    std::vector<float> alphas_;   // candidate values, ascending, last = 1
};

}  // namespace iris
