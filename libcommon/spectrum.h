// Spectrum -> linear RGB, exactly as Mitsuba 0.5 does in its RGB mode (no white balance):
// the piecewise-linear spectrum times each CIE 1931 2-degree matching function is integrated with an
// adaptive Gauss-Lobatto rule (rel./abs. tolerance 1e-4, at most 10000 evaluations) separately over
// 10 pieces of 47 nm ("50 nm-sized regions") of [360, 830] nm, divided by the integral of y-bar, and
// mapped XYZ -> linear sRGB (Rec. 709 primaries, D65 white). Two Mitsuba quirks matter and are
// reproduced (details and evidence at the top of spectrum.cpp): the scene parser zero-extends a sampled
// spectrum by one sample at the mean spacing on each side, and Mitsuba 0.5.0 interpolates each segment
// of a sampled curve backwards; with those, the README's measured emitter values come out to five
// digits. The backwards interpolation is a bug that Mitsuba's later core fixed: SpectrumInterpolation
// picks either (the scene setting spectrum-interpolation; the loader's default is the fixed one).
#pragma once

#include <string>
#include <vector>

#include "libcommon/color.h"

namespace iris {

// How a piecewise-linear spectrum (a scene's tabulated one, and the CIE tables) is evaluated between
// its samples. Mitsuba050: backwards inside each segment, as the Mitsuba 0.5.0 release does (the
// thesis's scenes and figures were made with it); Linear: the straight interpolation of Mitsuba's later
// core (the 0.6 fix of InterpolatedSpectrum::eval). Everything else (zero extension, quadrature) is the
// same in both. The two differ by up to ~13 % per channel on a peaked emission spectrum.
enum class SpectrumInterpolation { Linear, Mitsuba050 };

// Sampled spectrum given as (wavelength nm, value) pairs, strictly increasing wavelengths, at least two
// samples (std::invalid_argument otherwise), as a Mitsuba <spectrum value="l:v, ..."> converts it.
RGB spectrum_to_rgb(const std::vector<float>& wavelengths, const std::vector<float>& values,
                    SpectrumInterpolation interpolation = SpectrumInterpolation::Mitsuba050);

// A black body at `kelvin` (> 0, finite; std::invalid_argument otherwise) as Mitsuba's <blackbody>
// converts it: Planck's spectral radiance in W m^-2 sr^-1 nm^-1 (CODATA 2010 constants, as Mitsuba
// 0.5), integrated against the CIE tables exactly as a sampled spectrum is, negative channels clamped.
// The caller multiplies by the element's `scale`. About 4.3e4 in luminance at 6500 K.
RGB blackbody_to_rgb(float kelvin, SpectrumInterpolation interpolation = SpectrumInterpolation::Mitsuba050);

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
