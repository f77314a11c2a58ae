// The renderer's compact form of one cache's directional distribution (DESIGN 4.1): the map as a
// piecewise-constant 2D distribution in 16-bit integer counts, a marginal over its rows and, per row, a
// conditional over its texels, both as cumulative counts out of kRowTotal. Sampling a direction is two
// counts of the entries at or below a threshold (SIMD, no search), and a texel's density is the product
// of two count differences: a guided vertex does no arithmetic over a row. (The layout before it, an
// 8-bit log-spaced code per texel, summed a row's 32 decoded values for every density and scanned them
// for every sample: lookup + density + sample took 156 ns with the maps in L1 where this takes 115.)
// At R = 32 it takes 2112 bytes, twice the codes' 1088 and half the atlas's float cdf.
//
// The packed map is itself an exact distribution: sampling and the density read the same counts, so the
// density reported for a sample is the one it was drawn with and MIS stays unbiased. It differs from the
// atlas's density only by the rounding to counts: each row's and each texel's count is within one of its
// exact share of 65535 (every positive share gets at least one count, so zero densities are exactly the
// atlas's zeros), except the largest row of the map and the largest texel of each row, which take the
// rounding's total error (below R counts). That changes how well the map fits the light, not what the
// estimate converges to.
//
// Layout for resolution R, in bytes from a 64-byte aligned start:
//   [row_end: uint16[R], padded to 64][texel_end: uint16[R] per row, row after row, padded to 64]
// row_end[j] = the counts of rows 0..j (row_end[R - 1] = kRowTotal); texel_end of row j: the counts of
// its texels 0..i (the last kRowTotal for a row with a positive count, all zero otherwise). Texel
// k = j R + i (row-major as the atlas) has probability
//   P(k) = (row_end[j] - row_end[j - 1]) (texel_end[j][i] - texel_end[j][i - 1]) / kRowTotal^2.
// At R = 32 a row's texel_end is one 64-byte line: a density or a sample reads the row ends' line and
// one row's line.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "libcommon/math.h"
#include "libcommon/spheremap.h"

namespace iris::packed_map {

inline constexpr uint32_t kRowTotal = 65535;
// Largest resolution R whose rounding error fits the largest entry's counts (see encode).
inline constexpr int kMaxResolution = 256;

inline size_t round_up64(size_t n) { return (n + 63) / 64 * 64; }
inline size_t row_end_bytes(int R) { return round_up64(size_t(R) * sizeof(uint16_t)); }
// Bytes of one packed map of resolution R (a multiple of 64).
inline size_t bytes(int R) { return row_end_bytes(R) + round_up64(size_t(R) * size_t(R) * sizeof(uint16_t)); }

inline const uint16_t* row_end(const unsigned char* map) { return reinterpret_cast<const uint16_t*>(map); }
inline const uint16_t* texel_end(const unsigned char* map, int R, int j) {
    return reinterpret_cast<const uint16_t*>(map + row_end_bytes(R)) + size_t(j) * size_t(R);
}

// Writes the packed form of the density `pdf` (N = R * R non-negative finite values, per steradian or
// any common scale) into `map` (bytes(R), 64-byte aligned). All-zero densities pack as uniform.
// R must be in [1, kMaxResolution].
void encode(const float* pdf, int R, unsigned char* map);

// How many of the n cumulative counts a[0..n) are <= t (t < 65536): for nondecreasing a ending above
// t, the index of the first entry past t, i.e. the row (or texel) whose interval holds t.
inline int count_at_or_below(const uint16_t* a, int n, uint32_t t) {
    int c = 0, r = 0;
#if defined(__SSE2__)
    // Unsigned 16-bit compares through the signed ones: flipping the top bit keeps the order.
    const __m128i flip = _mm_set1_epi16(int16_t(0x8000));
    const __m128i tv = _mm_xor_si128(_mm_set1_epi16(int16_t(uint16_t(t))), flip);
    __m128i above = _mm_setzero_si128();  // per lane: minus the entries > t
    for (; r + 8 <= n; r += 8) {
        const __m128i v = _mm_xor_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a + r)), flip);
        above = _mm_add_epi16(above, _mm_cmpgt_epi16(v, tv));
    }
    // Horizontal sum of the eight lanes (each in [-n/8, 0]).
    above = _mm_add_epi16(above, _mm_srli_si128(above, 8));
    above = _mm_add_epi16(above, _mm_srli_si128(above, 4));
    above = _mm_add_epi16(above, _mm_srli_si128(above, 2));
    c = r + int(int16_t(_mm_cvtsi128_si32(above)));
#endif
    for (; r < n; ++r) c += a[r] <= t;
    return c;
}

// Density per steradian of a texel of `row` and `texel` counts: the one expression both texel_pdf and
// sample use, so their results agree bit for bit. (The product is below 2^32: exact in uint32.)
inline float density(uint32_t row, uint32_t texel, float per_sr) {
    constexpr float kInvTotal2 = float(1.0 / (double(kRowTotal) * double(kRowTotal)));
    return float(row * texel) * (per_sr * kInvTotal2);
}

inline uint32_t interval(const uint16_t* ends, int i, uint32_t* lo) {
    *lo = i > 0 ? ends[i - 1] : 0u;
    return uint32_t(ends[i]) - *lo;
}

// Density per steradian of texel (i, j) (column i, row j, both in [0, R)); per_sr = R * R / (4 pi).
inline float texel_pdf(const unsigned char* map, int R, int i, int j, float per_sr) {
    uint32_t lo;
    const uint32_t row = interval(row_end(map), j, &lo);
    if (row == 0) return 0.0f;
    return density(row, interval(texel_end(map, R, j), i, &lo), per_sr);
}
// The same for texel k = j R + i.
inline float texel_pdf(const unsigned char* map, int R, int k, float per_sr) {
    return texel_pdf(map, R, k % R, k / R, per_sr);
}

// u in [0, 1) as the map uses it (NaN and out-of-range values clamped).
inline float clamp_unit(float u) { return !(u >= 0.0f) ? 0.0f : std::min(u, 0x1.fffffep-1f); }

// The row that sample() picks for u.x, for prefetching.
inline int row_of(const unsigned char* map, int R, float ux) {
    return count_at_or_below(row_end(map), R, uint32_t(clamp_unit(ux) * float(kRowTotal)));
}

// Starts loading row j's texel counts into the CPU's caches.
inline void prefetch_row(const unsigned char* map, int R, int j) {
    const uint16_t* row = texel_end(map, R, j);
    prefetch(row);
    prefetch(row + R - 1);
}

// Samples a direction in the map's frame from u in [0, 1)^2 and sets *pdf to its density per
// steradian: texel_pdf of the texel whose density applies to it, bit for bit. u.x picks the row (by
// the row counts) and, rescaled inside the row's interval, the position along v inside it; u.y the
// texel in the row and the position along u inside it. Like SphereDistribution::sample, a point within
// kEdgeMargin of its texel's edge has its texel re-derived from the direction.
// `j` is row_of(map, R, u.x), found by the caller (who prefetched that row meanwhile).
// (texel, where given, receives the index dj R + di of the texel whose density *pdf is.)
inline Vec3 sample(const unsigned char* map, int R, Vec2 u, int j, float per_sr, float* pdf, int* texel_index = nullptr) {
    constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
    const float tx = clamp_unit(u.x) * float(kRowTotal), ty = clamp_unit(u.y) * float(kRowTotal);
    const uint16_t* ends = row_end(map);  // j < R: tx < kRowTotal = ends[R - 1]
    uint32_t lo_j, lo_i;
    const uint32_t row = interval(ends, j, &lo_j);  // > 0: tx lies in [lo_j, ends[j])
    const uint16_t* texels = texel_end(map, R, j);
    const int i = count_at_or_below(texels, R, uint32_t(ty));  // the row has counts: texels[R - 1] = kRowTotal
    const uint32_t texel = interval(texels, i, &lo_i);
    // Positions inside the texel, uniform in [0, 1) and independent of the texel chosen.
    const float fy = std::min((tx - float(lo_j)) / float(row), kOneMinusEpsilon);
    const float fx = std::min((ty - float(lo_i)) / float(texel), kOneMinusEpsilon);
    int di, dj;  // the texel whose density applies
    const Vec3 w = sphere_point_in_texel(i, j, fx, fy, R, &di, &dj);
    *pdf = di == i && dj == j ? density(row, texel, per_sr) : texel_pdf(map, R, di, dj, per_sr);
    if (texel_index) *texel_index = dj * R + di;
    return w;
}
inline Vec3 sample(const unsigned char* map, int R, Vec2 u, float per_sr, float* pdf) {
    return sample(map, R, u, row_of(map, R, u.x), per_sr, pdf);
}

}  // namespace iris::packed_map
