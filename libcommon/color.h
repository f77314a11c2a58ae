// Linear RGB radiometric quantities (radiance in W/(m^2 sr), power in W, reflectance unitless).
// iris renders in RGB, as Mitsuba 0.5 does in its RGB mode; spectra are converted on load (spectrum.h).
#pragma once

#include <cmath>

#include "libcommon/math.h"

namespace iris {

struct RGB {
    float r = 0, g = 0, b = 0;
    constexpr RGB() = default;
    constexpr RGB(float r_, float g_, float b_) : r(r_), g(g_), b(b_) {}
    constexpr explicit RGB(float s) : r(s), g(s), b(s) {}
    float operator[](int i) const { return (&r)[i]; }
    float& operator[](int i) { return (&r)[i]; }
};

inline RGB operator+(RGB a, RGB b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }
inline RGB operator-(RGB a, RGB b) { return {a.r - b.r, a.g - b.g, a.b - b.b}; }
inline RGB operator*(RGB a, RGB b) { return {a.r * b.r, a.g * b.g, a.b * b.b}; }
inline RGB operator*(RGB a, float s) { return {a.r * s, a.g * s, a.b * s}; }
inline RGB operator*(float s, RGB a) { return {a.r * s, a.g * s, a.b * s}; }
inline RGB operator/(RGB a, float s) { return a * (1.0f / s); }
inline RGB operator/(RGB a, RGB b) { return {a.r / b.r, a.g / b.g, a.b / b.b}; }
inline RGB& operator+=(RGB& a, RGB b) { return a = a + b; }
inline RGB& operator*=(RGB& a, RGB b) { return a = a * b; }
inline RGB& operator*=(RGB& a, float s) { return a = a * s; }
inline RGB& operator/=(RGB& a, float s) { return a = a * (1.0f / s); }
inline float max_component(RGB a) { return std::fmax(a.r, std::fmax(a.g, a.b)); }
inline float average(RGB a) { return (a.r + a.g + a.b) * (1.0f / 3.0f); }
// Rec. 709 luminance of linear RGB.
inline float luminance(RGB a) { return 0.212671f * a.r + 0.715160f * a.g + 0.072169f * a.b; }
inline bool is_black(RGB a) { return a.r == 0 && a.g == 0 && a.b == 0; }
inline bool is_finite(RGB a) { return std::isfinite(a.r) && std::isfinite(a.g) && std::isfinite(a.b); }
inline RGB rgb_sqrt(RGB a) { return {std::sqrt(a.r), std::sqrt(a.g), std::sqrt(a.b)}; }

}  // namespace iris
