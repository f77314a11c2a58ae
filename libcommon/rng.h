// Deterministic random numbers. Randomness comes from indices, never from threads: every pixel sample,
// photon path and cache derives its own generator from hash(seed, stage, index), so the output is the
// same for any thread count (STYLE.md, habit 5).
#pragma once

#include <cstdint>

namespace iris {

// SplitMix64 finaliser: a strong 64-bit mixer (Steele et al. 2014).
inline uint64_t mix64(uint64_t x) {
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

inline uint64_t hash_combine(uint64_t a, uint64_t b) { return mix64(a ^ mix64(b)); }
inline uint64_t hash3(uint64_t a, uint64_t b, uint64_t c) { return hash_combine(hash_combine(a, b), c); }

// Stage identifiers folded into seeds, so stages never share random streams.
enum class Stream : uint64_t { Camera = 1, Photons = 2, Caches = 3, Test = 4, LightPaths = 5 };

// PCG32 (O'Neill 2014): 64-bit state, 32-bit output, selectable stream.
class Rng {
public:
    Rng() : Rng(0, 0) {}
    Rng(uint64_t seed, uint64_t stream) { reset(seed, stream); }
    // A generator for item `index` of `stream` under the user's `seed`.
    static Rng for_index(uint64_t seed, Stream stream, uint64_t index) {
        return Rng(hash3(seed, uint64_t(stream), index), mix64(index));
    }
    void reset(uint64_t seed, uint64_t stream) {
        state_ = 0;
        inc_ = (stream << 1u) | 1u;
        next_u32();
        state_ += seed;
        next_u32();
    }
    uint32_t next_u32() {
        uint64_t old = state_;
        state_ = old * 6364136223846793005ULL + inc_;
        uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
    }
    // Uniform float in [0, 1): 24 random mantissa bits, never rounds up to 1.
    float next_float() { return float(next_u32() >> 8) * 0x1p-24f; }
    double next_double() {
        uint64_t v = (uint64_t(next_u32()) << 21) ^ uint64_t(next_u32());
        return double(v & ((1ULL << 53) - 1)) * 0x1p-53;
    }

private:
    uint64_t state_ = 0, inc_ = 1;
};

}  // namespace iris
