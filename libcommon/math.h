// Small vector maths for the renderer: 3-vectors in float, an orthonormal frame, a 4x4 affine transform.
// Plain structs and free functions (yocto-gl style); everything inline so the hot loops see through it.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace iris {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kInv2Pi = 0.15915494309189533577f;
inline constexpr float kInv4Pi = 0.07957747154594766788f;
inline constexpr float kInf = std::numeric_limits<float>::infinity();

// Starts loading the cache line holding p (a hint: no fault, no effect on results). Not
// __builtin_prefetch: GCC 12 deletes that where its address comes from a multiplicative hash (seen
// at -O1 to -O3: the guide's grid-slot prefetch compiled to nothing), so on x86 it is an asm
// statement the compiler must keep.
inline void prefetch(const void* p) {
#if defined(__x86_64__) || defined(__i386__)
    asm volatile("prefetcht0 %0" : : "m"(*static_cast<const char*>(p)));
#else
    __builtin_prefetch(p);
#endif
}

struct Vec2 {
    float x = 0, y = 0;
};

struct Vec3 {
    float x = 0, y = 0, z = 0;
    constexpr Vec3() = default;
    constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
    constexpr explicit Vec3(float s) : x(s), y(s), z(s) {}
    float operator[](int i) const { return (&x)[i]; }
    float& operator[](int i) { return (&x)[i]; }
};

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(float s, Vec3 a) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline Vec3 operator/(Vec3 a, float s) { return a * (1.0f / s); }
inline Vec3& operator+=(Vec3& a, Vec3 b) { return a = a + b; }
inline Vec3& operator-=(Vec3& a, Vec3 b) { return a = a - b; }
inline Vec3& operator*=(Vec3& a, float s) { return a = a * s; }
inline float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length_sq(Vec3 a) { return dot(a, a); }
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(Vec3 a) { return a / length(a); }
inline Vec3 vmin(Vec3 a, Vec3 b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3 vmax(Vec3 a, Vec3 b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline float max_component(Vec3 a) { return std::max(a.x, std::max(a.y, a.z)); }
inline float max_abs_component(Vec3 a) { return std::max(std::abs(a.x), std::max(std::abs(a.y), std::abs(a.z))); }
inline bool is_finite(Vec3 a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

template <class T>
inline T clamp(T v, T lo, T hi) { return std::min(std::max(v, lo), hi); }
inline float sqr(float x) { return x * x; }
// c ? a : b without a branch: for conditions that follow the data (a sampled direction's hemisphere),
// where a branch mispredicts about half the time (~15 cycles each on x86-64). Both a and b are
// computed whatever c is, so it pays only where they are cheap.
inline float select(bool c, float a, float b) {
    const uint32_t m = 0u - uint32_t(c);
    return std::bit_cast<float>((std::bit_cast<uint32_t>(a) & m) | (std::bit_cast<uint32_t>(b) & ~m));
}
// sqrt that tolerates tiny negative rounding errors (1 - cos^2 and friends).
inline float safe_sqrt(float x) { return std::sqrt(std::max(0.0f, x)); }
inline float safe_acos(float x) { return std::acos(clamp(x, -1.0f, 1.0f)); }

// Orthonormal basis with `n` as the local +z axis. Built with the branchless method of
// Duff et al. 2017 ("Building an Orthonormal Basis, Revisited"), which is stable for every n.
struct Frame {
    Vec3 s, t, n;
    Frame() : s(1, 0, 0), t(0, 1, 0), n(0, 0, 1) {}
    explicit Frame(Vec3 normal) : n(normal) {
        float sign = std::copysign(1.0f, n.z);
        float a = -1.0f / (sign + n.z);
        float b = n.x * n.y * a;
        s = Vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
        t = Vec3(b, sign + n.y * n.y * a, -n.y);
    }
    Vec3 to_local(Vec3 v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
    Vec3 to_world(Vec3 v) const { return s * v.x + t * v.y + n * v.z; }
};

// Row-major 4x4 affine transform in double precision (scene files compose long chains of these).
struct Transform {
    double m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};

    Vec3 point(Vec3 p) const {
        double r[3];
        for (int i = 0; i < 3; ++i) r[i] = m[i][0] * p.x + m[i][1] * p.y + m[i][2] * p.z + m[i][3];
        double w = m[3][0] * p.x + m[3][1] * p.y + m[3][2] * p.z + m[3][3];
        return Vec3(float(r[0] / w), float(r[1] / w), float(r[2] / w));
    }
    Vec3 vector(Vec3 v) const {
        double r[3];
        for (int i = 0; i < 3; ++i) r[i] = m[i][0] * v.x + m[i][1] * v.y + m[i][2] * v.z;
        return Vec3(float(r[0]), float(r[1]), float(r[2]));
    }
    Transform operator*(const Transform& o) const {
        Transform r;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                double s = 0;
                for (int k = 0; k < 4; ++k) s += m[i][k] * o.m[k][j];
                r.m[i][j] = s;
            }
        return r;
    }
    Transform inverse() const;    // general 4x4 inverse (Gauss-Jordan); identity-safe
    Transform transpose() const;
    // Normals transform with the inverse transpose; the result is normalised.
    Vec3 normal(Vec3 n) const;
    double determinant3x3() const;

    static Transform translate(Vec3 t);
    static Transform scale(Vec3 s);
    static Transform rotate(Vec3 axis, double degrees);
    // Mitsuba's lookAt: columns (left, up', dir, origin) with left = normalize(cross(up, dir)).
    static Transform look_at(Vec3 origin, Vec3 target, Vec3 up);
};

}  // namespace iris
