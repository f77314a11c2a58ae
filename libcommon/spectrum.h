// Spectrum -> linear RGB, exactly as Mitsuba 0.5 does in its RGB mode (no white balance):
// the piecewise-linear spectrum times each CIE 1931 2-degree matching function is integrated with an
// adaptive Gauss-Lobatto rule (rel./abs. tolerance 1e-4, at most 10000 evaluations) separately over
// 10 pieces of 47 nm ("50 nm-sized regions") of [360, 830] nm, divided by the integral of y-bar, and
// mapped XYZ -> linear sRGB (Rec. 709 primaries, D65 white). Two Mitsuba quirks matter and are
// reproduced (details and evidence at the top of spectrum.cpp): the scene parser zero-extends a sampled
// spectrum by one sample at the mean spacing on each side, and Mitsuba interpolates each segment of a
// sampled curve backwards; with those, the README's measured emitter values come out to five digits.
#pragma once

#include <string>
#include <vector>

#include "libcommon/color.h"

namespace iris {

// Sampled spectrum given as (wavelength nm, value) pairs, strictly increasing wavelengths, at least two
// samples (std::invalid_argument otherwise), as a Mitsuba 0.5 <spectrum value="l:v, ..."> converts it.
RGB spectrum_to_rgb(const std::vector<float>& wavelengths, const std::vector<float>& values);

// Exact integral of the (correctly) linearly interpolated spectrum, zero outside its first/last
// sample, against the linearly interpolated CIE tables, divided by the integral of y-bar; no zero
// extension, no clamping, double precision (for tests and comparison).
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
