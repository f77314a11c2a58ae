// Spectrum -> RGB conversion as Mitsuba 0.5 performs it in its RGB build, plus the colour-space helpers
// and the named-material tables (conductor eta/k, dielectric IOR) that the scene loader needs.
//
// What Mitsuba 0.5 actually computes for <spectrum value="l1:v1, l2:v2, ...">, established by
// reproducing the seed README's measured emitter values to five digits (and Mitsuba 3's published
// Cornell-box reflectances, which were converted the same way, to six):
//
//  1. The scene parser appends one zero sample on each side of the data ("zero extension"), at the
//     mean sample spacing, unless the spectrum already starts/ends at zero. A spectrum sampled
//     400..700 nm every 100 nm that ends at 18.4 therefore ramps down to 0 at 800 nm; it does not jump.
//  2. Its piecewise-linear spectrum class interpolates each segment *backwards*: between samples
//     (a, fa) and (b, fb) it returns fb at a+ and fa at b-, while exactly at a sample it returns that
//     sample. The integral of each segment is unchanged, but the product with a matching function is
//     not, and the curve jumps at every sample. This applies to the CIE tables (1 nm) as well.
//  3. Each of X, Y, Z is the average of spectrum * matching function over [360, 830] nm, integrated
//     in ceil(470/50) = 10 pieces of 47 nm by an adaptive Gauss-Lobatto rule (Gander & Gautschi 2000,
//     "Adaptive quadrature - revisited", the adaptlob scheme: a 4-point Lobatto rule checked against
//     the 7-point Kronrod extension, with a 13-point initial estimate that scales the tolerance),
//     relative and absolute tolerance 1e-4, at most 10000 evaluations per piece, all in float.
//     Because of the jumps in (2), the recursion runs into the evaluation cap, so the result depends
//     on the exact float arithmetic and recursion order; both are reproduced here.
//  4. X, Y, Z are divided by the trapezoidal average of y-bar over the same range and mapped to linear
//     Rec. 709 RGB with Mitsuba's matrix; negative components are clamped to zero.
//
// Step (3) makes the result depend on float rounding: this file must not be compiled with
// -ffast-math or with floating-point contraction into FMA (see the pragmas below).
#include "libcommon/spectrum.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

// Keep a*b+c as two roundings, as in Mitsuba's SSE2 build: a fused multiply-add would change which
// Gauss-Lobatto intervals are refined and hence the converted colour in the 4th-5th digit.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace iris {
namespace {

#include "libcommon/cie1931.inc"

constexpr float kCieFirst = float(kCieFirstNm);                  // nm
constexpr float kCieLast = float(kCieFirstNm + kCieCount - 1);   // nm

// Wavelengths of the CIE table as float (nm), the abscissae Mitsuba's interpolated CMFs use.
struct CieWavelengths {
    float nm[kCieCount];
    CieWavelengths() {
        for (int i = 0; i < kCieCount; ++i) nm[i] = float(kCieFirstNm + i);
    }
};
const CieWavelengths& cie_wavelengths() {
    static const CieWavelengths w;
    return w;
}

// A piecewise-linear spectrum evaluated the way Mitsuba 0.5's InterpolatedSpectrum::eval does,
// including its backwards interpolation inside each segment (point 2 above). Zero outside
// [w[0], w[n-1]]; the end points themselves are inside.
struct MitsubaCurve {
    const float* w = nullptr;  // nm, strictly increasing
    const float* v = nullptr;
    size_t n = 0;
    bool backwards = true;  // Mitsuba 0.5.0's interpolation; false: the corrected (0.6) one

    float eval(float lambda) const {
        if (n < 2 || lambda < w[0] || lambda > w[n - 1]) return 0.0f;
        // First sample >= lambda, and whether lambda hits it exactly (equal_range in Mitsuba).
        const float* hit = std::lower_bound(w, w + n, lambda);
        size_t i = size_t(hit - w);
        if (*hit == lambda) return v[i];
        float a = w[i - 1], b = w[i], fa = v[i - 1], fb = v[i];
        float t = (lambda - a) / (b - a);
        // Mitsuba 0.5.0's lerp(t, fb, fa): fb at the left end of the segment, fa at the right end.
        if (backwards) return (1.0f - t) * fb + t * fa;
        return (1.0f - t) * fa + t * fb;
    }

    // Mean over [lo, hi] of the correctly interpolated curve (trapezoids), in float, as Mitsuba's
    // InterpolatedSpectrum::average (which, unlike eval, interpolates the right way round).
    float average(float lo, float hi) const {
        if (n < 2) return 0.0f;
        float start = std::max(lo, w[0]), end = std::min(hi, w[n - 1]);
        if (end <= start) return 0.0f;
        size_t e = size_t(std::lower_bound(w, w + n, start) - w);
        e = std::max<size_t>(e, 1) - 1;
        float sum = 0.0f;
        for (; e + 1 < n && end >= w[e]; ++e) {
            float a = w[e], b = w[e + 1];
            float ca = std::max(a, start), cb = std::min(b, end);
            float fa = v[e], fb = v[e + 1], inv_ab = 1.0f / (b - a);
            if (cb <= ca) continue;
            float ta = (ca - a) * inv_ab, tb = (cb - a) * inv_ab;
            float ya = (1.0f - ta) * fa + ta * fb;
            float yb = (1.0f - tb) * fa + tb * fb;
            sum += 0.5f * (ya + yb) * (cb - ca);
        }
        return sum / (hi - lo);
    }
};

// Planck's law as Mitsuba 0.5's BlackBodySpectrum::eval computes it: in double, SI units, then per
// nanometre (the 1e-9) and rounded to float. `lambda` in nm, `kelvin` in K; W m^-2 sr^-1 nm^-1.
float planck(float lambda, float kelvin) {
    const double c = 299792458.0;      // speed of light, m/s
    const double k = 1.3806488e-23;    // Boltzmann constant, J/K (CODATA 2010, Mitsuba's value)
    const double h = 6.62606957e-34;   // Planck constant, J s (CODATA 2010)
    const double l = double(lambda) * 1e-9;  // m
    return float((2 * h * c * c) * std::pow(l, -5.0) / ((std::exp((h / k) * c / (l * double(kelvin))) - 1.0) * 1e9));
}

// Product of a spectrum and one matching function, the integrand of one tristimulus value. The
// spectrum is a sampled curve, or (curve null) a black body at `kelvin`.
struct Product {
    const MitsubaCurve* spectrum;
    const MitsubaCurve* cmf;
    float kelvin = 0;
    float operator()(float lambda) const {
        return (spectrum ? spectrum->eval(lambda) : planck(lambda, kelvin)) * cmf->eval(lambda);
    }
};

// Adaptive Gauss-Lobatto quadrature in float (Gander & Gautschi's adaptlob), with the tolerance
// handling of Mitsuba 0.5's GaussLobattoIntegrator: the stopping test is "is + (i1 - i2) == is" in
// float, where is = tolerance / machine epsilon, so a piece stops refining once the difference of
// its 4-point and 7-point estimates vanishes against the scaled tolerance.
class GaussLobatto {
public:
    GaussLobatto(size_t max_evals, float abs_tol, float rel_tol)
        : max_evals_(max_evals), abs_tol_(abs_tol), rel_tol_(rel_tol) {}

    float integrate(const Product& f, float a, float b) const {
        if (a == b) return 0.0f;
        float sign = 1.0f;
        if (b < a) {
            std::swap(a, b);
            sign = -1.0f;
        }
        size_t evals = 0;
        float tol = scaled_tolerance(f, a, b, evals);
        evals += 2;
        return sign * step(f, a, b, f(a), f(b), tol, evals);
    }

private:
    // Nodes of the 4-point Lobatto rule (+-1, +-1/sqrt 5) and its Kronrod extension (+-sqrt(2/3), 0),
    // and the three extra nodes of the 13-point rule used for the first estimate.
    static constexpr double kAlpha = 0.816496580927726032732;  // sqrt(2/3)
    static constexpr double kBeta = 0.447213595499957939282;   // 1/sqrt(5)
    static constexpr double kX1 = 0.94288241569547971906;
    static constexpr double kX2 = 0.64185334234578130578;
    static constexpr double kX3 = 0.23638319966214988028;

    // First, 13-point estimate of the integral, turned into the "is" of the stopping test.
    float scaled_tolerance(const Product& f, float a, float b, size_t& evals) const {
        const float alpha = float(kAlpha), beta = float(kBeta);
        const float x1 = float(kX1), x2 = float(kX2), x3 = float(kX3);
        const float m = (a + b) / 2, h = (b - a) / 2;
        const float y1 = f(a), y3 = f(m - alpha * h), y5 = f(m - beta * h), y7 = f(m);
        const float y9 = f(m + beta * h), y11 = f(m + alpha * h), y13 = f(b);
        // Weights of the 13-point rule; the sum is accumulated left to right as written.
        float s = float(0.0158271919734801831) * (y1 + y13);
        s = s + float(0.0942738402188500455) * (f(m - x1 * h) + f(m + x1 * h));
        s = s + float(0.1550719873365853963) * (y3 + y11);
        s = s + float(0.1888215739601824544) * (f(m - x2 * h) + f(m + x2 * h));
        s = s + float(0.1997734052268585268) * (y5 + y9);
        s = s + float(0.2249264653333395270) * (f(m - x3 * h) + f(m + x3 * h));
        s = s + float(0.2426110719014077338) * y7;
        const float acc = h * s;
        evals += 13;

        const float eps = std::numeric_limits<float>::epsilon();
        float result = std::numeric_limits<float>::infinity();
        if (rel_tol_ != 0 && acc != 0) result = acc * std::max(rel_tol_, eps) / eps;
        if (abs_tol_ != 0) result = std::min(result, abs_tol_ / eps);
        return result;
    }

    float step(const Product& f, float a, float b, float fa, float fb, float is, size_t& evals) const {
        const float alpha = float(kAlpha), beta = float(kBeta);
        const float h = (b - a) / 2, m = (a + b) / 2;
        const float mll = m - alpha * h, ml = m - beta * h, mr = m + beta * h, mrr = m + alpha * h;
        const float fmll = f(mll), fml = f(ml), fm = f(m), fmr = f(mr), fmrr = f(mrr);
        const float i2 = (h / 6) * (fa + fb + 5 * (fml + fmr));  // 4-point Lobatto
        const float i1 = (h / 1470) * (77 * (fa + fb) + 432 * (fmll + fmrr) + 625 * (fml + fmr) + 672 * fm);
        evals += 5;
        if (evals >= max_evals_) return i1;
        const float dist = is + (i1 - i2);
        if (dist == is || mll <= a || b <= mrr) return i1;
        // Refine the six sub-intervals left to right (the shared evaluation budget makes the order
        // matter once it runs out), and add them up in the same order.
        const float s1 = step(f, a, mll, fa, fmll, is, evals);
        const float s2 = step(f, mll, ml, fmll, fml, is, evals);
        const float s3 = step(f, ml, m, fml, fm, is, evals);
        const float s4 = step(f, m, mr, fm, fmr, is, evals);
        const float s5 = step(f, mr, mrr, fmr, fmrr, is, evals);
        const float s6 = step(f, mrr, b, fmrr, fb, is, evals);
        return s1 + s2 + s3 + s4 + s5 + s6;
    }

    size_t max_evals_;
    float abs_tol_, rel_tol_;
};

// Mean of spectrum * cmf over [lo, hi] nm, integrated in pieces of at most 50 nm (Mitsuba's
// ContinuousSpectrum::average).
float mitsuba_average(const Product& f, float lo, float hi) {
    if (hi <= lo) return 0.0f;
    const GaussLobatto quad(10000, 1e-4f, 1e-4f);
    size_t pieces = std::max<size_t>(1, size_t(std::ceil((hi - lo) / 50)));
    float width = (hi - lo) / float(pieces), pos = lo, integral = 0.0f;
    for (size_t i = 0; i < pieces; ++i) {
        integral += quad.integrate(f, pos, pos + width);
        pos += width;
    }
    return integral / (hi - lo);
}

// Mitsuba 0.5's Spectrum::fromContinuousSpectrum in RGB mode, then clampNegative. `s` null: a black
// body at `kelvin`. The CIE tables are interpolated like the spectrum (Mitsuba uses one class for both).
RGB mitsuba_curve_to_rgb(const MitsubaCurve* s, SpectrumInterpolation interpolation, float kelvin = 0) {
    const CieWavelengths& cw = cie_wavelengths();
    const bool backwards = interpolation == SpectrumInterpolation::Mitsuba050;
    const MitsubaCurve cx{cw.nm, kCieX, size_t(kCieCount), backwards};
    const MitsubaCurve cy{cw.nm, kCieY, size_t(kCieCount), backwards};
    const MitsubaCurve cz{cw.nm, kCieZ, size_t(kCieCount), backwards};
    float x = mitsuba_average(Product{s, &cx, kelvin}, kCieFirst, kCieLast);
    float y = mitsuba_average(Product{s, &cy, kelvin}, kCieFirst, kCieLast);
    float z = mitsuba_average(Product{s, &cz, kelvin}, kCieFirst, kCieLast);
    const float norm = 1.0f / cy.average(kCieFirst, kCieLast);
    x *= norm;
    y *= norm;
    z *= norm;
    RGB c = xyz_to_linear_srgb(x, y, z);
    return RGB(std::max(c.r, 0.0f), std::max(c.g, 0.0f), std::max(c.b, 0.0f));
}

void check_samples(const std::vector<float>& wavelengths, const std::vector<float>& values) {
    if (wavelengths.size() != values.size())
        throw std::invalid_argument("spectrum: wavelength and value counts differ");
    if (wavelengths.size() < 2)
        throw std::invalid_argument("spectrum: a sampled spectrum needs at least two samples");
    for (size_t i = 0; i < wavelengths.size(); ++i) {
        if (!std::isfinite(wavelengths[i]) || !std::isfinite(values[i]))
            throw std::invalid_argument("spectrum: non-finite sample");
        if (i > 0 && !(wavelengths[i] > wavelengths[i - 1]))
            throw std::invalid_argument("spectrum: wavelengths must increase strictly");
    }
}

// Value of the (correctly) linearly interpolated curve at lambda, zero outside [w.front(), w.back()].
// `i` is the index of the segment [w[i], w[i+1]] that contains lambda, found by the caller.
double lerp_segment(const std::vector<double>& w, const std::vector<double>& v, size_t i, double lambda) {
    double t = (lambda - w[i]) / (w[i + 1] - w[i]);
    return (1.0 - t) * v[i] + t * v[i + 1];
}

}  // namespace

RGB spectrum_to_rgb(const std::vector<float>& wavelengths, const std::vector<float>& values,
                    SpectrumInterpolation interpolation) {
    check_samples(wavelengths, values);
    // Mitsuba's scene parser zero-extends the samples at the mean spacing (point 1 above); the mean
    // is accumulated in float like InterpolatedSpectrum::zeroExtend.
    std::vector<float> w = wavelengths, v = values;
    float spacing = 0.0f;
    for (size_t i = 0; i + 1 < w.size(); ++i) spacing += w[i + 1] - w[i];
    spacing /= float(w.size() - 1);
    if (v.front() != 0.0f) {
        w.insert(w.begin(), w.front() - spacing);
        v.insert(v.begin(), 0.0f);
    }
    if (v.back() != 0.0f) {
        w.push_back(w.back() + spacing);
        v.push_back(0.0f);
    }
    const MitsubaCurve s{w.data(), v.data(), w.size(), interpolation == SpectrumInterpolation::Mitsuba050};
    return mitsuba_curve_to_rgb(&s, interpolation);
}

RGB blackbody_to_rgb(float kelvin, SpectrumInterpolation interpolation) {
    if (!(kelvin > 0) || !std::isfinite(kelvin))
        throw std::invalid_argument("blackbody: the temperature must be a positive number of kelvins");
    return mitsuba_curve_to_rgb(nullptr, interpolation, kelvin);
}

RGB spectrum_to_rgb_exact(const std::vector<float>& wavelengths, const std::vector<float>& values) {
    check_samples(wavelengths, values);
    std::vector<double> sw(wavelengths.begin(), wavelengths.end()), sv(values.begin(), values.end());
    std::vector<double> cw(kCieCount), cx(kCieX, kCieX + kCieCount), cy(kCieY, kCieY + kCieCount),
        cz(kCieZ, kCieZ + kCieCount);
    for (int i = 0; i < kCieCount; ++i) cw[i] = kCieFirstNm + i;

    // Both factors are linear between consecutive breakpoints of the merged set (spectrum samples and
    // whole nanometres inside the overlap), so each piece is a quadratic and Simpson's rule is exact.
    const double lo = std::max(sw.front(), cw.front()), hi = std::min(sw.back(), cw.back());
    double X = 0, Y = 0, Z = 0;
    if (hi > lo) {
        std::vector<double> bp;
        for (double x : sw)
            if (x >= lo && x <= hi) bp.push_back(x);
        for (double x = std::ceil(lo); x <= hi; x += 1.0) bp.push_back(x);
        bp.push_back(lo);
        bp.push_back(hi);
        std::sort(bp.begin(), bp.end());
        bp.erase(std::unique(bp.begin(), bp.end()), bp.end());
        size_t si = 0;
        for (size_t p = 0; p + 1 < bp.size(); ++p) {
            const double a = bp[p], b = bp[p + 1], m = 0.5 * (a + b);
            while (si + 2 < sw.size() && sw[si + 1] <= a) ++si;
            const size_t ci = std::min<size_t>(size_t(a - cw.front()), size_t(kCieCount - 2));
            const double s0 = lerp_segment(sw, sv, si, a), s1 = lerp_segment(sw, sv, si, m),
                         s2 = lerp_segment(sw, sv, si, b);
            auto simpson = [&](const std::vector<double>& c) {
                return (b - a) / 6.0 *
                       (s0 * lerp_segment(cw, c, ci, a) + 4.0 * s1 * lerp_segment(cw, c, ci, m) +
                        s2 * lerp_segment(cw, c, ci, b));
            };
            X += simpson(cx);
            Y += simpson(cy);
            Z += simpson(cz);
        }
    }
    double norm = 0;  // integral of y-bar over [360, 830] nm (trapezoids are exact for the linear CMF)
    for (int i = 0; i + 1 < kCieCount; ++i) norm += 0.5 * (cy[i] + cy[i + 1]);
    return xyz_to_linear_srgb(float(X / norm), float(Y / norm), float(Z / norm));
}

RGB xyz_to_linear_srgb(float x, float y, float z) {
    // ITU-R BT.709 primaries, D65 white, the matrix Mitsuba 0.5 uses (Spectrum::fromXYZ).
    return RGB(3.240479f * x + -1.537150f * y + -0.498535f * z,
               -0.969256f * x + 1.875991f * y + 0.041556f * z,
               0.055648f * x + -0.204043f * y + 1.057311f * z);
}

float srgb_to_linear(float v) {
    // IEC 61966-2-1 transfer function (the same constants as Mitsuba's fromSRGBComponent).
    if (v <= 0.04045f) return v * (1.0f / 12.92f);
    return std::pow((v + 0.055f) * (1.0f / 1.055f), 2.4f);
}

float linear_to_srgb(float v) {
    if (v <= 0.0031308f) return 12.92f * v;
    return 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

bool conductor_ior(const std::string& name, RGB* eta, RGB* k) {
    // RGB-mode complex IORs of Mitsuba's named conductors. Source: Mitsuba 0.5's data/ior/<name>.eta.spd
    // and <name>.k.spd (measured data from the luxpop.com database), converted here by the exact
    // integral of the linearly interpolated samples against the 1 nm CIE 1931 tables over 360-830 nm
    // (spectrum_to_rgb_exact, no zero extension: the conductor plugin reads the files directly).
    // These equal the seed README's values for Cu and the tables other renderers (e.g. Tungsten) use.
    // Mitsuba 0.5 itself would push the same files through its backwards segment interpolation (see
    // the top of this file), which moves eta by up to 4 % (Cu red: 0.2082 instead of 0.2004) but the
    // normal-incidence reflectance by under 0.2 %; we keep the conventional values.
    struct Entry {
        const char* name;
        RGB eta, k;
    };
    static const Entry table[] = {
        {"Ag", {0.155265f, 0.116723f, 0.138381f}, {4.828343f, 3.122246f, 2.146950f}},
        {"Al", {1.657460f, 0.880369f, 0.521229f}, {9.223869f, 6.269523f, 4.837001f}},
        {"Au", {0.143119f, 0.374957f, 1.442479f}, {3.983160f, 2.385721f, 1.603215f}},
        {"Cr", {4.369683f, 2.916703f, 1.654701f}, {5.206434f, 4.231364f, 3.754947f}},
        {"Cu", {0.200438f, 0.924033f, 1.102212f}, {3.912949f, 2.452848f, 2.142188f}},
        {"W", {4.370703f, 3.300297f, 2.998267f}, {3.500678f, 2.604865f, 2.273193f}},
    };
    std::string lower = name;
    for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (lower == "none") {
        // Mitsuba's "none": a perfect mirror, eta 0 and k 1 give Fresnel reflectance 1 at all angles.
        *eta = RGB(0.0f);
        *k = RGB(1.0f);
        return true;
    }
    for (const Entry& e : table)
        if (name == e.name) {
            *eta = e.eta;
            *k = e.k;
            return true;
        }
    return false;
}

bool dielectric_ior(const std::string& name, float* ior) {
    // Mitsuba 0.5's table of named dielectrics (bsdfs/ior.h, documented in its manual), refractive
    // indices near 589 nm. Names are matched case-insensitively, as Mitsuba does.
    struct Entry {
        const char* name;
        float ior;
    };
    static const Entry table[] = {
        {"vacuum", 1.0f},           {"helium", 1.00004f},        {"hydrogen", 1.00013f},
        {"air", 1.00028f},          {"carbon dioxide", 1.00045f}, {"water", 1.3330f},
        {"acetone", 1.36f},         {"ethanol", 1.361f},         {"carbon tetrachloride", 1.461f},
        {"glycerol", 1.4729f},      {"benzene", 1.501f},         {"silicone oil", 1.52045f},
        {"bromine", 1.661f},        {"water ice", 1.31f},        {"fused quartz", 1.458f},
        {"pyrex", 1.470f},          {"acrylic glass", 1.49f},    {"polypropylene", 1.49f},
        {"bk7", 1.5046f},           {"sodium chloride", 1.544f}, {"amber", 1.55f},
        {"pet", 1.5750f},           {"diamond", 2.419f},
    };
    std::string lower = name;
    for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
    for (const Entry& e : table)
        if (lower == e.name) {
            *ior = e.ior;
            return true;
        }
    return false;
}

}  // namespace iris
