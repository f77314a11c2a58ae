// Spherical density maps for the radiance caches (DESIGN.md §1 step 3, §4 items 1, 2, 4, 7).
//
// A cache stores the distribution of incident directions over the FULL sphere, in the cache's local
// frame (iris::Frame of its normal, local +z = normal). Directions are laid out on the unit square by
// Clarberg's equal-area octahedral map (P. Clarberg, "Fast Equal-Area Mapping of the (Hemi)Sphere
// using SIMD", JGT 2008): the inner diamond |u'|+|v'| < 1 of the square (u', v' in [-1, 1]) is the
// upper hemisphere (+z at the centre), the four corner triangles are the lower hemisphere (-z at all
// four corners). The map is area-preserving: its Jacobian is 4 pi sr per unit square area, so every
// texel of an R x R grid covers exactly 4 pi / R^2 sr and a density that is constant per texel in the
// square is constant per steradian inside the texel. That is what makes the cache PDF exact (§4.1):
// no Monte-Carlo texel areas, no "constant inside a texel" approximation.
//
// Topology of the layout (§4.7): the square's border folds onto itself. A point on an edge is the
// same direction as its mirror image about that edge's midpoint ((u, 1) ~ (1 - u, 1) in [0, 1]^2
// coordinates, likewise for the other three edges), and all four corners are -z. Stepping across an
// edge therefore continues at the mirrored position on the same edge, never at the opposite edge
// (a toroidal wrap would join directions ~90-180 degrees apart).
//
// Texel (i, j) covers [i/R, (i+1)/R) x [j/R, (j+1)/R) of the square; i runs along u (x), j along v
// (y); its flat index is k = j R + i (row-major).
//
// Pieces:
//   square_to_sphere / sphere_to_square   the map and its exact inverse (inline: hot path)
//   sphere_texel_*                        texel index, centre direction, neighbour across folds
//   SphereMap                             float weights per texel: splat photons, filter, floor
//   SphereFilter                          a precomputed Gaussian filter on the sphere, per (R, sigma)
//   SphereDistribution                    pmf/cdf/pdf tables; sample/pdf/invert (also on raw
//                                         pointers, to check an atlas's tables in place)
// The renderer samples a compact copy of each map (libguide/packed_map.h).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "libcommon/math.h"
#include "libcommon/sampling.h"

namespace iris {

// ---- Clarberg's equal-area octahedral map -----------------------------------------------------------

// The map needs one azimuth per direction each way: an atan2 (sphere -> square, every density lookup)
// and a sin/cos pair (square -> sphere, every cache sample). As libm calls they were 4.7 % of a render
// guiding every vertex (perf, glass spheres); on the narrow ranges the map uses, polynomials reach float
// rounding in a few multiply-adds. Both are within 1.5e-7 absolute of double libm (2-3 float ULPs of 1;
// tested), far below the round-trip tolerance the map's contract states (1e-6 in the square).

// The polynomials are evaluated in Estrin's scheme (pairs of terms, then pairs of pairs): without FMA
// (the baseline x86-64 build) each Horner step is a dependent multiply and add, and a density lookup
// waits on this chain.

// atan(t) * 2 / pi for t in [0, 1]: t P(t^2), P a degree-7 least-squares fit on Chebyshev nodes
// (truncation error 2.7e-8; exact 0 at t = 0, 0.5 at t = 1 to 3e-8).
inline float atan_unit_fraction(float t) {
    const float s = t * t, s2 = s * s, s4 = s2 * s2;
    const float q0 = 6.366192981e-01f - 2.121825335e-01f * s, q1 = 1.269625390e-01f - 8.844345465e-02f * s;
    const float q2 = 6.113494814e-02f - 3.526799536e-02f * s, q3 = 1.370012070e-02f - 2.522942766e-03f * s;
    return t * ((q0 + q1 * s2) + (q2 + q3 * s2) * s4);
}

// cos and sin of (1 + t) pi / 4 for t in [-1, 1] (the quadrant's azimuth), from the Taylor series of
// sin x and cos x at x = t pi / 4 in [-pi/4, pi/4] (truncation below 2e-9) and the angle sum with pi/4.
inline void quadrant_cos_sin(float t, float* c, float* s) {
    const float x = t * (0.25f * kPi), x2 = x * x, x4 = x2 * x2, x8 = x4 * x4;
    const float sx = x * ((1.0f - x2 * (1.0f / 6)) + (1.0f / 120 - x2 * (1.0f / 5040)) * x4 + x8 * (1.0f / 362880));
    const float cx = (1.0f - 0.5f * x2) + (1.0f / 24 - x2 * (1.0f / 720)) * x4 + (1.0f / 40320 - x2 * (1.0f / 3628800)) * x8;
    constexpr float kSqrtHalf = 0.70710678118654752f;
    *c = (cx - sx) * kSqrtHalf;
    *s = (cx + sx) * kSqrtHalf;
}

// Square [0,1]^2 -> unit direction. Uniform points in the square map to uniform directions (Jacobian
// 4 pi sr per unit area). (0.5, 0.5) is +z, the corners are -z, edge midpoints are +-x, +-y.
// Inputs outside [0,1]^2 are not meaningful (clamp first); the result is always finite and unit.
inline Vec3 square_to_sphere(Vec2 uv) {
    // To [-1, 1]^2, then work in the first quadrant on |u|, |v|; the signs of u, v are those of x, y.
    const float u = 2.0f * uv.x - 1.0f, v = 2.0f * uv.y - 1.0f;
    const float au = std::abs(u), av = std::abs(v);
    const float l1 = au + av;  // 1 on the equator (the diamond), < 1 inside (upper hemisphere)
    const bool upper = l1 <= 1.0f;
    // r: "radius" from the nearest pole, 0 at +-z, 1 on the equator; 1 - r^2 = |z|. Computed as
    // l1 (resp. 2 - l1) rather than 1 - |1 - l1| so that it keeps full precision near +z.
    // (The hemisphere and azimuth choices here and in sphere_to_square are selects, not branches: they
    // follow the direction, which a cache sample draws at random. sphere_to_square keeps its branches
    // on |z| > 0.5 and at the poles: there both sides cost a division, and in the render they
    // mispredict little -- cachegrind's counts, docs/BENCHMARKS.md.)
    const float r = select(upper, l1, 2.0f - l1);
    // Azimuth inside the quadrant is linear in (|v| - |u|) / r (in [-1, 1]): the lines of constant
    // azimuth are the rays from the pole through the diamond. At the poles (r = 0) any value will do.
    const float t = select(r > 0.0f, clamp((av - au) / r, -1.0f, 1.0f), 0.0f);
    float cos_phi, sin_phi;  // phi = (t + 1) pi / 4 in [0, pi/2]
    quadrant_cos_sin(t, &cos_phi, &sin_phi);
    const float z_abs = 1.0f - r * r;
    // sin(theta) = sqrt(1 - z^2) = r sqrt(2 - r^2): exact near the poles, unlike sqrt(1 - z^2).
    const float s = r * safe_sqrt(2.0f - r * r);
    return {std::copysign(cos_phi * s, u), std::copysign(sin_phi * s, v), select(upper, z_abs, -z_abs)};
}

// Unit direction -> square [0,1]^2, the exact inverse of square_to_sphere. `w` must be unit length
// (to float rounding). Directions on the square's border (the half-meridians x = 0 or y = 0 with
// z < 0) have two preimages; the one chosen depends only on the direction's value (signed zeros are
// treated as +0), so equal directions always land in the same texel.
inline Vec2 sphere_to_square(Vec3 w) {
    const float ax = std::abs(w.x), ay = std::abs(w.y), az = std::abs(w.z);
    // 1 - |z| of a float unit vector is quantised to ULP(1) = 6e-8 near the poles; derive it from
    // x^2 + y^2 = (1 - |z|)(1 + |z|) there (same trick as one_minus_cos_theta in sampling.h).
    const float one_minus_z = az > 0.5f ? (ax * ax + ay * ay) / (1.0f + az) : 1.0f - az;
    const float r = std::min(1.0f, safe_sqrt(one_minus_z));
    // Azimuth inside the quadrant as a fraction in [0, 1] (0 at +x, 1 at +y), from the smaller of the
    // two ratios (in [0, 1]); 0 at the poles, as atan2(0, 0).
    const float lo = std::min(ax, ay), hi = std::max(ax, ay);
    const float half = atan_unit_fraction(hi > 0.0f ? lo / hi : 0.0f);  // in [0, 0.5]
    const float a = std::min(1.0f, select(ay > ax, 1.0f - half, half));
    // Upper hemisphere: |u| + |v| = r and |v| - |u| = r (2a - 1).
    const float av_up = r * a, au_up = r - av_up;
    // Lower hemisphere: reflect the inner triangle onto the corner triangle, (|u|,|v|) ->
    // (1 - |v|, 1 - |u|), which keeps |v| - |u| (the azimuth) and maps |u|+|v| = r to 2 - r.
    const bool lower = w.z < 0.0f;
    const float au = select(lower, 1.0f - av_up, au_up), av = select(lower, 1.0f - au_up, av_up);
    // The signs of x and y (-0 as +0: -0 + 0 = +0).
    const float u = std::copysign(au, w.x + 0.0f), v = std::copysign(av, w.y + 0.0f);
    return {clamp(0.5f * u + 0.5f, 0.0f, 1.0f), clamp(0.5f * v + 0.5f, 0.0f, 1.0f)};
}

// Solid angle of one texel of an R x R octahedral grid, in sr: exactly 4 pi / R^2 (equal-area map).
inline float sphere_texel_solid_angle(int R) { return 4.0f * kPi / float(R * R); }

// Flat index j R + i of the texel containing direction `w` (unit). Directions exactly on a texel
// edge go to the texel above/right of the edge (the one whose half-open square contains the point);
// u = 1 or v = 1 go to the last texel. Robust for every finite unit w, seams and poles included.
inline void sphere_texel_of(Vec3 w, int R, int* i, int* j) {
    const Vec2 uv = sphere_to_square(w);
    const float fx = uv.x * float(R), fy = uv.y * float(R);
    // `>= 0` is false for NaN, so a NaN direction lands in texel 0 instead of undefined behaviour.
    *i = fx >= 0.0f ? std::min(int(fx), R - 1) : 0;
    *j = fy >= 0.0f ? std::min(int(fy), R - 1) : 0;
}
inline int sphere_texel_of(Vec3 w, int R) {
    int i, j;
    sphere_texel_of(w, R, &i, &j);
    return j * R + i;
}

// Direction of the centre of texel (i, j) (0 <= i, j < R).
inline Vec3 sphere_texel_center(int i, int j, int R) {
    return square_to_sphere({(float(i) + 0.5f) / float(R), (float(j) + 0.5f) / float(R)});
}

// Texel reached from (i, j) by stepping (di, dj) texels in the square, following the sphere's
// topology: a step across an edge of the square continues at the mirrored texel of the same edge
// (j = R -> j' = R - 1 with i' = R - 1 - i, and so on), a diagonal step across a corner reaches the
// diagonally opposite corner texel (all four corners touch -z). Valid for |di|, |dj| <= R.
// Returns the flat index j' R + i'.
inline int sphere_texel_neighbour(int i, int j, int di, int dj, int R) {
    i += di;
    j += dj;
    // Fold in u: (u, v) with u outside [0, 1] is the same direction as (mirror(u), 1 - v). The v fold
    // after it sees the already mirrored v; the two folds commute (checked in the tests).
    if (i < 0) {
        i = -1 - i;
        j = R - 1 - j;
    } else if (i >= R) {
        i = 2 * R - 1 - i;
        j = R - 1 - j;
    }
    if (j < 0) {
        j = -1 - j;
        i = R - 1 - i;
    } else if (j >= R) {
        j = 2 * R - 1 - j;
        i = R - 1 - i;
    }
    return j * R + i;
}

// ---- Gaussian filter on the sphere ------------------------------------------------------------------

// A Gaussian filter for R x R octahedral maps, precomputed once per (R, sigma) and reused for any
// number of maps (thread-safe: apply() is const and allocation-free).
//
// Each source texel s spreads its mass over the texels t whose centre directions lie within 3 sigma
// (angle on the sphere, radians) of its own, with weights exp(-theta_st^2 / (2 sigma^2)) normalised
// to sum to 1 over those t ("scatter" form). Because the neighbourhoods are found by angle on the
// sphere, the filter follows the sphere's topology across every seam and fold of the layout (§4.7),
// and because every source's weights sum to one the filter preserves total mass exactly (up to float
// rounding). It is stored transposed (a gather per target texel: out[t] = sum_s w_st/W_s in[s]) so
// that apply() writes each output once.
class SphereFilter {
public:
    SphereFilter() = default;
    // sigma <= 0 (or so small that no other texel centre is within 3 sigma) gives the identity.
    // Cost O(N^2) with N = R^2; do it once, not per cache.
    SphereFilter(int resolution, float sigma_radians);

    int resolution() const { return R_; }
    float sigma() const { return sigma_; }
    // Total number of (target, source) taps; apply() costs one multiply-add per tap.
    int taps() const { return int(src_.size()); }
    // out[t] = filtered in; `in` and `out` hold R*R floats each and must not overlap.
    void apply(const float* in, float* out) const;

private:
    int R_ = 0;
    float sigma_ = 0;
    std::vector<int> row_begin_;  // size N+1: taps of target t are [row_begin_[t], row_begin_[t+1])
    std::vector<int> src_;        // source texel of each tap
    std::vector<float> weight_;   // w_st / W_s of each tap
};

// ---- the map that caches are built in ----------------------------------------------------------------

// Float weights over the texels of an R x R octahedral map (1 <= R <= 256), in the cache's local
// frame. Built per cache: splat photons, filter, normalise with a floor, then build a
// SphereDistribution (or write its tables into the atlas with SphereDistribution::build). Reuse one
// map per thread with clear() to avoid allocating per cache.
class SphereMap {
public:
    SphereMap() = default;
    explicit SphereMap(int resolution);

    int resolution() const { return R_; }
    int size() const { return R_ * R_; }
    void clear() { std::fill(w_.begin(), w_.end(), 0.0f); }
    float* data() { return w_.data(); }
    const float* data() const { return w_.data(); }
    float& operator[](int k) { return w_[size_t(k)]; }
    float operator[](int k) const { return w_[size_t(k)]; }
    float& at(int i, int j) { return w_[size_t(j * R_ + i)]; }
    float at(int i, int j) const { return w_[size_t(j * R_ + i)]; }
    // Sum of all weights (in double).
    double total() const;

    int texel_of(Vec3 w) const { return sphere_texel_of(w, R_); }
    Vec3 texel_center(int i, int j) const { return sphere_texel_center(i, j, R_); }
    int texel_neighbour(int i, int j, int di, int dj) const { return sphere_texel_neighbour(i, j, di, dj, R_); }

    // Adds `value` at direction `w` (unit, local frame) by bilinear weights over the 4 texels around
    // w's continuous texel coordinate (texel centres at half-integers), neighbours taken across the
    // square's folds (sphere topology). The 4 weights sum to 1: the map's total grows by `value`.
    void splat(Vec3 w, float value);
    // Adds `value` to the single texel containing w (no interpolation).
    void splat_nearest(Vec3 w, float value) { w_[size_t(texel_of(w))] += value; }

    // Gaussian smoothing on the sphere with a precomputed filter (its resolution must match; throws
    // std::invalid_argument otherwise). Preserves the total. Uses an internal scratch buffer, so a map
    // is not to be filtered from two threads at once.
    void filter(const SphereFilter& f);
    // Convenience for one-off use: builds a SphereFilter(R, sigma) and applies it. O(N^2) per call;
    // for many caches build one SphereFilter and call filter(f).
    void gaussian_filter(float sigma_radians);

    // Normalises to a probability mass function with a guaranteed floor (§4.4):
    //     p_k <- (1 - f) * w_k / sum(w) + f / N,
    // i.e. a mixture of the map with the uniform distribution on the sphere, of weight f in [0, 1].
    // Every texel then has p_k >= f/N, so the per-steradian density is >= f/(4 pi) everywhere: any
    // direction from which light can arrive keeps a finite MIS weight. A mixture (rather than raising
    // only the zero texels to a constant) keeps the ratios between the map's texels and states the
    // floor as a fraction of the total mass, independent of R. A map with no positive weight (or a
    // non-finite total) becomes uniform. The result sums to 1 (renormalised in double against
    // rounding). Weights must be >= 0; throws std::invalid_argument for f outside [0, 1].
    void normalise_floor(float floor_fraction);

private:
    int R_ = 0;
    std::vector<float> w_;        // R*R weights, index j R + i
    std::vector<float> scratch_;  // filter output buffer, kept to avoid per-cache allocation
};

// ---- sampling a map ---------------------------------------------------------------------------------

// Piecewise-constant density over the sphere, constant inside each texel of an R x R octahedral map.
// Two tables of N = R^2 floats, index j R + i:
//   cdf[k]  cumulative probability of texels 0..k; non-decreasing, cdf[N-1] = 1 exactly;
//   pdf[k]  density per steradian inside texel k: pmf_k N / (4 pi), with pmf_k = cdf[k] - cdf[k-1]
//           (cdf[-1] = 0). The pmf is DEFINED by the stored float cdf, so the probability with which
//           sample() picks texel k (u.x against the cdf) is exactly the pmf that pdf[] reports:
//           no drift between the sampler and the density from rounding the cdf to float.
// Both sample() and pdf() take directions in the cache's local frame ("one frame, one cache", §4.2).
// The static overloads work on raw table pointers, so a cache stored in an atlas's flat arrays can be
// sampled without copying it.
class SphereDistribution {
public:
    SphereDistribution() = default;
    // From non-negative weights (not necessarily normalised): pmf proportional to the weights.
    explicit SphereDistribution(const SphereMap& map);
    SphereDistribution(const float* weights, int resolution);

    // Writes the cdf and pdf tables (N floats each) of the distribution proportional to `weights`.
    // Texels of weight 0 get probability exactly 0 (never sampled, pdf 0); a texel of positive weight
    // gets a non-empty cdf interval even when its share rounds below one float ULP of the cdf (as long
    // as the cdf has not reached 1 before it: weights below ~1e-7 of the total at the end of the
    // table can still end up with probability 0, which the floor of normalise_floor rules out).
    // All-zero weights give the uniform distribution. Throws std::invalid_argument for negative or
    // non-finite weights (they would silently bias estimates).
    static void build(const float* weights, int resolution, float* cdf, float* pdf);

    // Samples a direction (local frame) from u in [0,1)^2 and reports its density per steradian in
    // *pdf_out (if non-null). u.x picks the texel by a search of the cdf and, rescaled inside the
    // texel's cdf interval, gives the position along u; u.y gives the position along v. The density is
    // pdf[k] — constant inside the texel because the map is equal-area — and is bit-for-bit the value
    // pdf(w) returns for the returned w (near texel edges the texel is re-derived from w, see below).
    // A reported density of 0 (only possible next to a zero-weight texel, i.e. without a floor) means
    // "no sample". Pitfall: use the reported density for this sample's MIS weight; re-evaluating pdf()
    // on the direction after a to_world/to_local round trip can land in the neighbour texel when the
    // sample lies within rounding of a texel edge.
    static inline Vec3 sample(const float* cdf, const float* pdf, int resolution, Vec2 u, float* pdf_out);
    // Density per steradian of direction w (unit, local frame): pdf[texel of w].
    static inline float pdf(const float* pdf_table, int resolution, Vec3 w) {
        return pdf_table[sphere_texel_of(w, resolution)];
    }
    // The u that sample() maps to w (up to float rounding), for w in a texel of positive probability.
    static inline Vec2 invert(const float* cdf, int resolution, Vec3 w);

    Vec3 sample(Vec2 u, float* pdf_out) const { return sample(cdf_.data(), pdf_.data(), R_, u, pdf_out); }
    float pdf(Vec3 w) const { return pdf(pdf_.data(), R_, w); }
    Vec2 invert(Vec3 w) const { return invert(cdf_.data(), R_, w); }

    int resolution() const { return R_; }
    int size() const { return R_ * R_; }
    // Probability of texel k (per texel, sums to 1).
    float pmf(int k) const { return k > 0 ? cdf_[size_t(k)] - cdf_[size_t(k - 1)] : cdf_[0]; }
    const std::vector<float>& cdf() const { return cdf_; }
    const std::vector<float>& pdf_table() const { return pdf_; }

    // Points generated by sample() closer than this (in square units) to a texel edge have their texel
    // re-derived from the direction, so that the reported density is exactly pdf(w): float rounding in
    // the square -> sphere -> square round trip is below 1e-6 (tested), so further from the edge the
    // round trip cannot leave the chosen texel and the re-derivation (an atan2) is skipped.
    static constexpr float kEdgeMargin = 1e-5f;

    // First k with cdf[k] > u (as std::upper_bound, branch-free); requires cdf[n-1] > u.
    static inline int search_cdf(const float* cdf, int n, float u);

private:
    // The direction of u inside texel k (chosen for ux), with its density.
    // Sets *density_texel to the texel whose density applies to the direction (k, or its neighbour
    // when rounding moved a point near the edge across it).
    static inline Vec3 sample_texel(const float* cdf, int R, int k, float ux, float uy, int* density_texel);
    int R_ = 0;
    std::vector<float> cdf_, pdf_;
};

// First index k with cdf[k] > u (std::upper_bound), for a non-decreasing cdf with cdf[n-1] > u:
// P(k) = cdf[k] - cdf[k-1] exactly for uniform u, and zero-width (zero-probability) texels are never
// returned. Branch-free (sampling.h): std::upper_bound's unpredictable branches cost ~90 ns per search
// over 256 texels, this ~10 ns.
inline int SphereDistribution::search_cdf(const float* cdf, int n, float u) {
    return int(upper_bound_index(cdf, size_t(n), u));
}

inline Vec3 SphereDistribution::sample(const float* cdf, const float* pdf, int R, Vec2 u, float* pdf_out) {
    constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
    // u in [0, 1); the negated comparisons also send NaN to 0.
    const float ux = !(u.x >= 0.0f) ? 0.0f : std::min(u.x, kOneMinusEpsilon);
    const float uy = !(u.y >= 0.0f) ? 0.0f : std::min(u.y, kOneMinusEpsilon);
    int texel;
    const Vec3 w = sample_texel(cdf, R, search_cdf(cdf, R * R, ux), ux, uy, &texel);
    if (pdf_out) *pdf_out = pdf[texel];
    return w;
}

// The direction of the point ((i + fx) / R, (j + fy) / R) of the square, fx and fy in [0, 1) (a point
// inside texel (i, j)), with in *di, *dj the texel whose density applies to it: (i, j), except within
// SphereDistribution::kEdgeMargin of the texel's edge, where rounding may put the direction's preimage in
// the neighbour texel and the texel is re-derived from the direction -- so that a sample reports exactly
// the density a lookup of its direction reads. Every sampler of a map (SphereDistribution, the packed
// map, the guide's product) places its point with this.
inline Vec3 sphere_point_in_texel(int i, int j, float fx, float fy, int R, int* di, int* dj) {
    const float inv_r = 1.0f / float(R);
    const Vec3 w = square_to_sphere({(float(i) + fx) * inv_r, (float(j) + fy) * inv_r});
    const float m = SphereDistribution::kEdgeMargin * float(R);  // the margin in texel units
    *di = i;
    *dj = j;
    if (fx < m || fx > 1.0f - m || fy < m || fy > 1.0f - m) sphere_texel_of(w, R, di, dj);
    return w;
}

inline Vec3 SphereDistribution::sample_texel(const float* cdf, int R, int k, float ux, float uy, int* density_texel) {
    constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
    const float lo = k > 0 ? cdf[k - 1] : 0.0f;
    // ux rescaled to [0, 1) inside the texel's interval: uniform and independent of k.
    const float fx = clamp((ux - lo) / (cdf[k] - lo), 0.0f, kOneMinusEpsilon);
    // Equal-area map: the density is constant inside texel k (or the neighbour a point at its edge
    // rounds into, which pdf(w) reads).
    int di, dj;
    const Vec3 w = sphere_point_in_texel(k % R, k / R, fx, uy, R, &di, &dj);
    *density_texel = dj * R + di;
    return w;
}

inline Vec2 SphereDistribution::invert(const float* cdf, int R, Vec3 w) {
    constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
    const Vec2 uv = sphere_to_square(w);
    const int k = sphere_texel_of(w, R);
    const int i = k % R, j = k / R;
    const float fx = clamp(uv.x * float(R) - float(i), 0.0f, kOneMinusEpsilon);
    const float fy = clamp(uv.y * float(R) - float(j), 0.0f, kOneMinusEpsilon);
    const float lo = k > 0 ? cdf[k - 1] : 0.0f;
    return {std::min(lo + fx * (cdf[k] - lo), kOneMinusEpsilon), fy};
}

}  // namespace iris
