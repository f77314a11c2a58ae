#include "libcommon/texture.h"

#include <cmath>

namespace iris {

namespace {

// Maps a texel index to [0, n) per the wrap mode; -1 means "outside: the constant texel" (Zero, One).
inline int wrap_index(int i, int n, WrapMode m) {
    switch (m) {
        case WrapMode::Repeat: {
            int r = i % n;
            return r < 0 ? r + n : r;
        }
        case WrapMode::Mirror: {
            int p = i % (2 * n);
            if (p < 0) p += 2 * n;
            return p < n ? p : 2 * n - 1 - p;
        }
        case WrapMode::Clamp: return i < 0 ? 0 : (i >= n ? n - 1 : i);
        case WrapMode::Zero:
        case WrapMode::One: return (i < 0 || i >= n) ? -1 : i;
    }
    return 0;
}

inline RGB texel(const Texture& t, int x, int y) {
    int xi = wrap_index(x, t.width, t.wrap_u);
    int yi = wrap_index(y, t.height, t.wrap_v);
    if (xi < 0 || yi < 0) {
        // Outside with Zero/One in either direction: the constant (Mitsuba treats each axis alike).
        WrapMode m = xi < 0 ? t.wrap_u : t.wrap_v;
        return RGB(m == WrapMode::One ? 1.0f : 0.0f);
    }
    return t.texels[size_t(yi) * size_t(t.width) + size_t(xi)];
}

// Float coordinates far outside int range (huge uscale, or uv from a broken mesh) are clamped before
// the conversion, which would otherwise be undefined; 2^30 texels away every wrap mode is periodic or
// constant anyway, so this changes no value a sane scene can ask for.
inline int to_index(float f) {
    constexpr float kLimit = 1073741824.0f;  // 2^30
    if (!(f > -kLimit)) return -(1 << 30);   // also catches NaN
    if (f > kLimit) return 1 << 30;
    return int(std::floor(f));
}

// The four texels around texel-space position (x, y) and the position's fractions between their centres,
// which sit at half-integer positions.
struct Bilinear {
    RGB a, b, c, d;  // (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)
    float fx, fy;
};
inline Bilinear bilinear(const Texture& t, float x, float y) {
    const float xs = x - 0.5f, ys = y - 0.5f;
    const int x0 = to_index(xs), y0 = to_index(ys);
    Bilinear q;
    q.fx = xs - std::floor(xs);
    q.fy = ys - std::floor(ys);
    if (!(q.fx >= 0.0f && q.fx <= 1.0f)) q.fx = 0.0f;  // NaN / overflowed coordinates
    if (!(q.fy >= 0.0f && q.fy <= 1.0f)) q.fy = 0.0f;
    q.a = texel(t, x0, y0);
    q.b = texel(t, x0 + 1, y0);
    q.c = texel(t, x0, y0 + 1);
    q.d = texel(t, x0 + 1, y0 + 1);
    return q;
}

}  // namespace

RGB texture_eval(const Texture& t, Vec2 uv) {
    const float u = uv.x * t.uscale + t.uoffset;
    const float v = uv.y * t.vscale + t.voffset;
    if (t.type == TextureType::Checkerboard) {
        // Mitsuba 0.5's checkerboard: squares of 0.5 in (u, v), the cell index truncated towards zero
        // (int cast, not floor, so the square straddling 0 is twice as wide, as in Mitsuba).
        auto cell = [](float c) {
            float s = c * 2.0f;
            int i = (s > -1e9f && s < 1e9f) ? int(s) : 0;
            int m = i % 2;
            return m < 0 ? m + 2 : m;
        };
        return cell(u) == cell(v) ? t.color0 : t.color1;
    }
    const float x = u * float(t.width), y = v * float(t.height);
    if (t.filter == TextureFilter::Nearest) return texel(t, to_index(x), to_index(y));
    const Bilinear q = bilinear(t, x, y);
    return (q.a * (1.0f - q.fx) + q.b * q.fx) * (1.0f - q.fy) + (q.c * (1.0f - q.fx) + q.d * q.fx) * q.fy;
}

void texture_gradient(const Texture& t, Vec2 uv, RGB* d_du, RGB* d_dv) {
    *d_du = *d_dv = RGB(0.0f);
    if (t.type == TextureType::Checkerboard || t.filter == TextureFilter::Nearest) return;
    const float x = (uv.x * t.uscale + t.uoffset) * float(t.width), y = (uv.y * t.vscale + t.voffset) * float(t.height);
    const Bilinear q = bilinear(t, x, y);
    // d/dx of the interpolant times dx/du = width * uscale (likewise for v).
    *d_du = ((q.b - q.a) * (1.0f - q.fy) + (q.d - q.c) * q.fy) * (float(t.width) * t.uscale);
    *d_dv = ((q.c - q.a) * (1.0f - q.fx) + (q.d - q.b) * q.fx) * (float(t.height) * t.vscale);
}

}  // namespace iris
