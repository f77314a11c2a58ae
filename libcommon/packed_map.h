// The renderer's compact form of one cache's directional distribution (DESIGN 4.1): an 8-bit code per
// texel, log-spaced, and a 16-bit cdf over the map's rows. At R = 32 it takes 1088 bytes where the
// atlas's float cdf takes 4096, so the renderer holds a quarter of the memory per cache (4.6 instead of
// 17 MB for the 4000 caches of the glass spheres). Measured on the 2-core VM (every vertex guided, 5
// interleaved renders each): time per sample unchanged (2.71 s against 2.72 s), noise per sample
// unchanged (relMSE 0.0590 both); a guided vertex's extra cost is half arithmetic, and 4.6 MB still
// misses the few MB of last-level cache such a machine gives one process.
//
// The packed map is itself an exact distribution: sampling and the density read the same numbers, so
// the density reported for a sample is the one it was drawn with and MIS stays unbiased. It differs
// from the atlas's density only by the quantisation (a code is within 2^(1/32), 2.2 %, of its
// texel's share of the cache's brightest texel; a row's probability within 1/65535 absolute, the
// largest row's within R/65535): that changes how well the map fits the light, not what the estimate
// converges to.
//
// Layout for resolution R, in bytes from a 64-byte aligned start:
//   [row_end: uint16[R], padded to 64][code: uint8[R * R], row-major as the atlas (k = j R + i), padded to 64]
// row_end[j] = the counts of rows 0..j out of kRowTotal (row_end[R - 1] = kRowTotal). Texel k = j R + i
// has probability
//   P(k) = (row_end[j] - row_end[j - 1]) / kRowTotal * value(code[k]) / S_j,   S_j = sum of row j's values,
// value(0) = 0 (a texel never sampled) and value(c) = 2^((c - 255) / 16) relative to the brightest
// texel (code 255); texels dimmer than 2^-15.9 of it get code 1. A row is sampled (count > 0) exactly
// when some texel of it has a positive code.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "libcommon/math.h"
#include "libcommon/spheremap.h"

namespace iris::packed_map {

inline constexpr uint32_t kRowTotal = 65535;
inline constexpr int kStepsPerOctave = 16;

// value(c) for every code c (a table: the renderer's inner loops decode a row at a time).
inline const std::array<float, 256> kValue = [] {
    std::array<float, 256> v{};
    for (int c = 1; c < 256; ++c) v[size_t(c)] = float(std::exp2(double(c - 255) / kStepsPerOctave));
    return v;
}();

inline size_t round_up64(size_t n) { return (n + 63) / 64 * 64; }
inline size_t row_end_bytes(int R) { return round_up64(size_t(R) * sizeof(uint16_t)); }
// Bytes of one packed map of resolution R (a multiple of 64).
inline size_t bytes(int R) { return row_end_bytes(R) + round_up64(size_t(R) * size_t(R)); }

inline const uint16_t* row_end(const unsigned char* map) { return reinterpret_cast<const uint16_t*>(map); }
inline const unsigned char* codes(const unsigned char* map, int R) { return map + row_end_bytes(R); }

// Writes the packed form of the density `pdf` (N = R * R non-negative finite values, per steradian or
// any common scale) into `map` (bytes(R), 64-byte aligned). All-zero densities pack as uniform.
void encode(const float* pdf, int R, unsigned char* map);

// Sum of the values of a row's codes, always added in the same order (sampling and density agree).
inline float row_sum(const unsigned char* row, int R) {
    float a0 = 0, a1 = 0, a2 = 0, a3 = 0;
    int i = 0;
    for (; i + 4 <= R; i += 4) {
        a0 += kValue[row[i]];
        a1 += kValue[row[i + 1]];
        a2 += kValue[row[i + 2]];
        a3 += kValue[row[i + 3]];
    }
    for (; i < R; ++i) a0 += kValue[row[i]];
    return (a0 + a1) + (a2 + a3);
}

// Density per steradian of a texel of value v in a row of `count` counts and value sum S (count > 0):
// the one expression both texel_pdf and sample use, so their results agree bit for bit.
inline float density(uint32_t count, float v, float S, float per_sr) {
    return float(count) * (per_sr / float(kRowTotal)) * v / S;
}

// Density per steradian of texel k (0 <= k < R * R); per_sr = R * R / (4 pi).
inline float texel_pdf(const unsigned char* map, int R, int k, float per_sr) {
    const int j = k / R;
    const uint16_t* ends = row_end(map);
    const uint32_t count = uint32_t(ends[j]) - (j > 0 ? uint32_t(ends[j - 1]) : 0u);
    if (count == 0) return 0.0f;
    const unsigned char* row = codes(map, R) + size_t(j) * size_t(R);
    return density(count, kValue[row[k - j * R]], row_sum(row, R), per_sr);
}

// The row that sample() picks for u.x (the same clamping), for prefetching.
inline int row_of(const unsigned char* map, int R, float ux) {
    const float u = !(ux >= 0.0f) ? 0.0f : std::min(ux, 0x1.fffffep-1f);
    const uint32_t t = uint32_t(u * float(kRowTotal));  // < kRowTotal = row_end[R - 1]
    const uint16_t* ends = row_end(map);
    int j = 0;
    for (int r = 0; r < R; ++r) j += ends[r] <= t;  // rows ending at or before t: the first row past t
    return j;
}

// Starts loading row j's codes into the CPU's caches.
inline void prefetch_row(const unsigned char* map, int R, int j) {
    const unsigned char* row = codes(map, R) + size_t(j) * size_t(R);
    __builtin_prefetch(row);
    __builtin_prefetch(row + R - 1);
}

// Samples a direction in the map's frame from u in [0, 1)^2 and sets *pdf to its density per
// steradian: texel_pdf of the texel whose density applies to it, bit for bit. u.x picks the row
// (by the row counts) and, rescaled inside the row's interval, the texel (by the codes' values) and
// the position along u inside it; u.y gives the position along v. Like SphereDistribution::sample,
// a point within kEdgeMargin of its texel's edge has its texel re-derived from the direction.
inline Vec3 sample(const unsigned char* map, int R, Vec2 u, float per_sr, float* pdf) {
    constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
    const float ux = !(u.x >= 0.0f) ? 0.0f : std::min(u.x, kOneMinusEpsilon);
    const float uy = !(u.y >= 0.0f) ? 0.0f : std::min(u.y, kOneMinusEpsilon);
    const float t = ux * float(kRowTotal);
    const int j = row_of(map, R, ux);
    const uint16_t* ends = row_end(map);
    const uint32_t lo = j > 0 ? ends[j - 1] : 0u, count = uint32_t(ends[j]) - lo;
    // ux's position inside the row's interval, uniform in [0, 1) and independent of j.
    const float x = std::min((t - float(lo)) / float(count), kOneMinusEpsilon);
    const unsigned char* row = codes(map, R) + size_t(j) * size_t(R);
    const float S = row_sum(row, R);
    const float target = x * S;
    // The first texel whose cumulative value exceeds the target; zero-valued texels are never taken
    // (rounding may leave the target past the row's last positive texel: that one is taken).
    int i = -1;
    float before = 0, value = 0, acc = 0;
    for (int c = 0; c < R; ++c) {
        const float v = kValue[row[c]];
        if (v > 0) {
            i = c, before = acc, value = v;
            if (acc + v > target) break;
        }
        acc += v;
    }
    const float fx = clamp((target - before) / value, 0.0f, kOneMinusEpsilon);
    const float inv_r = 1.0f / float(R);
    const Vec3 w = square_to_sphere({(float(i) + fx) * inv_r, (float(j) + uy) * inv_r});
    const float m = SphereDistribution::kEdgeMargin * float(R);  // the margin in texel units
    const bool near_edge = fx < m || fx > 1.0f - m || uy < m || uy > 1.0f - m;
    const int k = j * R + i, density_texel = near_edge ? sphere_texel_of(w, R) : k;
    *pdf = density_texel == k ? density(count, value, S, per_sr) : texel_pdf(map, R, density_texel, per_sr);
    return w;
}

}  // namespace iris::packed_map
