// Spectrum -> linear RGB, exactly as Mitsuba 0.5 does in its RGB mode (no white balance):
// the piecewise-linear spectrum times each CIE 1931 2-degree matching function is integrated with an
// adaptive Gauss-Lobatto rule (rel./abs. tolerance 1e-4, at most 10000 evaluations) separately over
// 50 nm sub-intervals of [360, 830] nm, divided by the integral of y-bar, and mapped XYZ -> linear
// sRGB (Rec. 709 primaries, D65 white). A spectrum that ends at its last sample jumps to zero there;
// the adaptive rule lands on Mitsuba's values across that jump (seed-scenes/README.md).
#pragma once

#include <string>
#include <vector>

#include "libcommon/color.h"

namespace iris {

// Sampled spectrum given as (wavelength nm, value) pairs, sorted by wavelength; zero outside.
RGB spectrum_to_rgb(const std::vector<float>& wavelengths, const std::vector<float>& values);

// Exact integral of the piecewise-linear spectrum against the CIE tables (for tests and comparison).
RGB spectrum_to_rgb_exact(const std::vector<float>& wavelengths, const std::vector<float>& values);

// CIE 1931 XYZ -> linear sRGB / Rec. 709.
RGB xyz_to_linear_srgb(float x, float y, float z);

// sRGB-encoded value (0..1) -> linear.
float srgb_to_linear(float v);
// linear -> sRGB-encoded value (0..1, unclipped above 1).
float linear_to_srgb(float v);

// Named conductor data (Mitsuba's material list, e.g. "Cu", "Au", "Ag", "Al", "Cr", "none"),
// as RGB-mode eta and k. Returns false if the name is unknown.
bool conductor_ior(const std::string& name, RGB* eta, RGB* k);
// Named dielectric IORs (Mitsuba's list: "vacuum", "air", "water", "bk7", "polypropylene", ...).
bool dielectric_ior(const std::string& name, float* ior);

}  // namespace iris
