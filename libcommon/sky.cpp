// Daylight (declared and described in sky.h): solar position, the Hosek-Wilkie RGB sky, Preetham's sun
// and their rasterisation into an environment map, as Mitsuba 0.5's sky/sun/sunsky plugins compute them.
#include "libcommon/sky.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "libcommon/spectrum.h"

namespace iris {
namespace {

#include "libcommon/sky_data.inc"

constexpr double kPiD = 3.14159265358979323846;

double deg_to_rad(double d) { return d * (kPiD / 180.0); }

// ---------------------------------------------------------------------------------------------
// Solar position (Blanco-Muriel et al. 2001). Angles in radians, times in days or hours as named.

// Julian day number of a civil date at 0h UT is (JDN - 0.5): the integer algorithm of Fliegel and van
// Flandern (1968), with C's truncating division as the published algorithm assumes.
long julian_day_number(int year, int month, int day) {
    const long a = (long(month) - 14) / 12;
    return (1461 * (long(year) + 4800 + a)) / 4 + (367 * (long(month) - 2 - 12 * a)) / 12 -
           (3 * ((long(year) + 4900 + a) / 100)) / 4 + long(day) - 32075;
}

}  // namespace

SkyAngles sun_position(const SunDateTime& when, const SunPlace& place) {
    // Universal time in decimal hours, and days since JD 2451545.0 (noon UT, 1 January 2000).
    const double ut_hours = when.hour - place.timezone + (when.minute + when.second / 60.0) / 60.0;
    const double jd = double(julian_day_number(when.year, when.month, when.day)) - 0.5 + ut_hours / 24.0;
    const double n = jd - 2451545.0;

    // Ecliptic longitude and obliquity (radians, not reduced to [0, 2 pi)): the PSA algorithm's
    // fitted series in the mean longitude, mean anomaly and the longitude of the Moon's ascending node.
    const double node = 2.1429 - 0.0010394594 * n;
    const double mean_longitude = 4.8950630 + 0.017202791698 * n;
    const double mean_anomaly = 6.2400600 + 0.0172019699 * n;
    const double ecl_longitude = mean_longitude + 0.03341607 * std::sin(mean_anomaly) +
                                 0.00034894 * std::sin(2 * mean_anomaly) - 0.0001134 - 0.0000203 * std::sin(node);
    const double obliquity = 0.4090928 - 6.2140e-9 * n + 0.0000396 * std::cos(node);

    // Right ascension and declination.
    const double sin_l = std::sin(ecl_longitude);
    double right_ascension = std::atan2(std::cos(obliquity) * sin_l, std::cos(ecl_longitude));
    if (right_ascension < 0) right_ascension += 2 * kPiD;
    const double declination = std::asin(std::sin(obliquity) * sin_l);

    // Local coordinates: Greenwich mean sidereal time (hours), the local one (radians), hour angle.
    const double gmst_hours = 6.6974243242 + 0.0657098283 * n + ut_hours;
    const double lmst = deg_to_rad(gmst_hours * 15 + place.longitude);
    const double lat = deg_to_rad(place.latitude);
    const double hour_angle = lmst - right_ascension;
    const double cos_ha = std::cos(hour_angle);
    double zenith = std::acos(std::cos(lat) * cos_ha * std::cos(declination) + std::sin(declination) * std::sin(lat));
    double azimuth = std::atan2(-std::sin(hour_angle), std::tan(declination) * std::cos(lat) - std::sin(lat) * cos_ha);
    if (azimuth < 0) azimuth += 2 * kPiD;
    // Parallax: the observer is on the Earth's surface, not at its centre (mean radius / astronomical
    // unit, both in km).
    zenith += (6371.01 / 149597890.0) * std::sin(zenith);
    return {zenith, azimuth};
}

Vec3 sky_direction(SkyAngles a) {
    const double st = std::sin(a.theta);
    return Vec3(float(std::sin(a.phi) * st), float(std::cos(a.theta)), float(-std::cos(a.phi) * st));
}

SkyAngles sky_angles(Vec3 d) {
    double phi = std::atan2(double(d.x), -double(d.z));
    if (phi < 0) phi += 2 * kPiD;
    return {std::acos(std::clamp(double(d.y), -1.0, 1.0)), phi};
}

// ---------------------------------------------------------------------------------------------
// Hosek-Wilkie sky

namespace {

// Quintic Bernstein polynomial with control points c[0], c[stride], ..., c[5 * stride] at x in [0, 1]:
// the model's interpolation of every coefficient over the solar elevation.
double bezier5(const double* c, size_t stride, double x) {
    static const double kBinomial[6] = {1, 5, 10, 10, 5, 1};
    double sum = 0;
    for (int k = 0; k < 6; ++k) sum += kBinomial[k] * std::pow(1 - x, 5 - k) * std::pow(x, k) * c[size_t(k) * stride];
    return sum;
}

}  // namespace

HosekWilkieSky::HosekWilkieSky(double turbidity, RGB albedo, double sun_zenith) {
    if (!(turbidity >= 1 && turbidity <= 10))
        throw std::invalid_argument("sky turbidity " + std::to_string(turbidity) + " is outside [1, 10]");
    for (int c = 0; c < 3; ++c)
        if (!(albedo[c] >= 0 && albedo[c] <= 1)) throw std::invalid_argument("sky albedo is outside [0, 1]");
    if (!(sun_zenith >= 0 && sun_zenith <= kPiD / 2))
        throw std::invalid_argument("the sun is below the horizon (the sky model needs it above)");
    // The tables are indexed by the solar elevation's cube root over [0, pi/2]; turbidity is linear
    // between the integers below and above it (only the last table at 10), albedo between 0 and 1.
    const double x = std::cbrt((kPiD / 2 - sun_zenith) / (kPiD / 2));
    const int t_low = std::min(int(turbidity), 10);
    const double t_frac = turbidity - t_low;
    for (int c = 0; c < 3; ++c) {
        std::fill(coef_[c], coef_[c] + 9, 0.0);
        scale_[c] = 0;
        const double a = albedo[c];
        for (int ai = 0; ai < 2; ++ai)
            for (int ti = 0; ti < 2; ++ti) {
                const int t = t_low + ti;
                const double w = (ai ? a : 1 - a) * (ti ? t_frac : 1 - t_frac);
                if (t > 10 || w == 0) continue;
                for (int i = 0; i < 9; ++i) coef_[c][i] += w * bezier5(&kHosekRgb[c][ai][t - 1][0][i], 9, x);
                scale_[c] += w * bezier5(&kHosekRgbRadiance[c][ai][t - 1][0], 1, x);
            }
        // Mitsuba's RGB build divides the model's RGB by the sum of the CIE y-bar samples (1 nm).
        scale_[c] /= 106.856980;
    }
}

RGB HosekWilkieSky::radiance(double theta, double gamma) const {
    const double cos_t = std::cos(theta), cos_g = std::cos(gamma);
    RGB out;
    for (int c = 0; c < 3; ++c) {
        const double* k = coef_[c];  // A..I
        const double mie = (1 + cos_g * cos_g) / std::pow(1 + k[8] * k[8] - 2 * k[8] * cos_g, 1.5);
        const double f = (1 + k[0] * std::exp(k[1] / (cos_t + 0.01))) *
                         (k[2] + k[3] * std::exp(k[4] * gamma) + k[5] * cos_g * cos_g + k[6] * mie +
                          k[7] * std::sqrt(std::max(0.0, cos_t)));
        out[c] = float(f * scale_[c]);
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// Preetham sun

namespace {

// Linear interpolation in a table, zero outside its first and last wavelength (nm).
template <size_t N>
double table(const double (&nm)[N], const double (&v)[N], double lambda) {
    if (lambda < nm[0] || lambda > nm[N - 1]) return 0.0;
    size_t i = size_t(std::upper_bound(nm, nm + N, lambda) - nm);
    if (i >= N) return v[N - 1];
    const double t = (lambda - nm[i - 1]) / (nm[i] - nm[i - 1]);
    return (1 - t) * v[i - 1] + t * v[i];
}

}  // namespace

void sun_spectrum(double sun_zenith, double turbidity, std::vector<float>* wavelengths, std::vector<float>* values) {
    if (!(turbidity >= 1 && turbidity <= 10))
        throw std::invalid_argument("sun turbidity " + std::to_string(turbidity) + " is outside [1, 10]");
    if (!(sun_zenith >= 0 && sun_zenith <= kPiD / 2))
        throw std::invalid_argument("the sun is below the horizon");
    // Aerosol amount (Angstrom's beta) from turbidity, Preetham's fit; relative optical air mass
    // (Kasten's formula, zenith angle in degrees inside the power).
    const double beta = 0.04608365822050 * turbidity - 0.04586025928522;
    const double m = 1.0 / (std::cos(sun_zenith) + 0.15 * std::pow(93.885 - sun_zenith * (180.0 / kPiD), -1.253));
    wavelengths->clear();
    values->clear();
    for (int i = 0; i < 91; ++i) {
        const double nm = 350.0 + 5.0 * i, um = nm / 1000.0;
        const double tau_rayleigh = std::exp(-m * 0.008735 * std::pow(um, -4.08));
        const double tau_aerosol = std::exp(-m * beta * std::pow(um, -1.3));  // alpha = 1.3
        const double tau_ozone = std::exp(-m * table(kOzoneNm, kOzone, nm) * 0.35);  // 0.35 cm of ozone
        const double kg = table(kMixedGasNm, kMixedGas, nm);
        const double tau_gas = std::exp(-1.41 * kg * m / std::pow(1 + 118.93 * kg * m, 0.45));
        const double kwa = table(kWaterVapourNm, kWaterVapour, nm);
        const double w = 2.0;  // precipitable water vapour, cm
        const double tau_water = std::exp(-0.2385 * kwa * w * m / std::pow(1 + 20.07 * kwa * w * m, 0.45));
        wavelengths->push_back(float(nm));
        values->push_back(
            float(table(kSolarNm, kSolar, nm) * tau_rayleigh * tau_aerosol * tau_ozone * tau_gas * tau_water));
    }
}

RGB sun_radiance(double sun_zenith, double turbidity) {
    std::vector<float> w, v;
    sun_spectrum(sun_zenith, turbidity, &w, &v);
    // The exact integral of the piecewise-linear spectrum; Mitsuba 0.5.0 interpolates each 5 nm segment
    // backwards and integrates adaptively, which moves the result by less than 1e-4 (sky.md).
    RGB c = spectrum_to_rgb_exact(w, v);
    return RGB(std::max(c.r, 0.0f), std::max(c.g, 0.0f), std::max(c.b, 0.0f));
}

double sun_angular_radius() { return deg_to_rad(0.5358 * 0.5); }

float sun_solid_angle() {
    // 1 - cos of a 0.27 degree angle in float keeps only ~3 digits; Mitsuba's build computes it so,
    // and its sun's power follows (0.2 % below the exact value).
    const float theta = float(sun_angular_radius());
    return float(2 * kPiD * double(1.0f - std::cos(theta)));
}

// ---------------------------------------------------------------------------------------------
// Rasterisation

namespace {

// Mitsuba's fixed point set for the disk: the base-2 van der Corput sequence (24 bits kept, as its
// single-precision build) and the second Sobol dimension -- a (0,2)-sequence in base 2.
float van_der_corput(uint32_t n) {
    uint32_t r = 0;
    for (int b = 0; b < 32; ++b) r |= ((n >> b) & 1u) << (31 - b);
    return float(r >> 8) / float(1u << 24);
}
float sobol_dim2(uint32_t n) {
    uint32_t r = 0;
    for (uint32_t v = 1u << 31; n != 0; n >>= 1, v ^= v >> 1)
        if (n & 1) r ^= v;
    return float(double(r) / 4294967296.0);
}

// An orthonormal basis (s, t, n) around the unit n, the one Mitsuba's Frame builds (its choice of s
// decides where on the disk each point of the sequence lands).
void basis(Vec3 n, Vec3* s, Vec3* t) {
    if (std::abs(n.x) > std::abs(n.y)) {
        const float inv = 1.0f / std::sqrt(n.x * n.x + n.z * n.z);
        *t = Vec3(n.z * inv, 0.0f, -n.x * inv);
    } else {
        const float inv = 1.0f / std::sqrt(n.y * n.y + n.z * n.z);
        *t = Vec3(0.0f, n.z * inv, -n.y * inv);
    }
    *s = cross(*t, n);
}

void check_params(const SunSkyParams& p) {
    if (p.resolution < 2) throw std::invalid_argument("sunsky resolution must be at least 2");
    if (!(p.stretch >= 1 && p.stretch <= 2)) throw std::invalid_argument("sky stretch is outside [1, 2]");
    for (float s : {p.sky_scale, p.sun_scale, p.sun_radius_scale})
        if (!(s >= 0) || !std::isfinite(s)) throw std::invalid_argument("sunsky scales must be finite and >= 0");
}

// 0 below 0, 1 above 1, and the cubic 3 v^2 - 2 v^3 between: `extend`'s fade-out towards the nadir.
double smooth_step(double v) {
    v = std::clamp(v, 0.0, 1.0);
    return v * v * (3 - 2 * v);
}

// The sky at each texel centre, times sky_scale (Mitsuba's SkyEmitter::getSkyRadiance).
void rasterise_sky(const SunSkyParams& p, int width, int height, std::vector<RGB>* texels) {
    const HosekWilkieSky sky(p.turbidity, p.albedo, p.sun.theta);
    const double cos_s = std::cos(p.sun.theta), sin_s = std::sin(p.sun.theta);
    for (int y = 0; y < height; ++y) {
        const double view_theta = (y + 0.5) * kPiD / height;
        double theta = view_theta / p.stretch;
        if (std::cos(theta) <= 0) {
            if (!p.extend) continue;         // below the horizon: black
            theta = 0.5 * kPiD - 1e-4;       // `extend`: the horizon's radiance, faded out below
        }
        const double fade = p.extend ? smooth_step(2 - 2 * view_theta / kPiD) : 1.0;
        for (int x = 0; x < width; ++x) {
            const double phi = (x + 0.5) * 2 * kPiD / width;
            const double cos_gamma = std::cos(theta) * cos_s + std::sin(theta) * sin_s * std::cos(phi - p.sun.phi);
            const double gamma = std::acos(std::clamp(cos_gamma, -1.0, 1.0));
            RGB v = sky.radiance(theta, gamma);
            v = RGB(std::max(v.r, 0.0f), std::max(v.g, 0.0f), std::max(v.b, 0.0f)) * float(fade * p.sky_scale);
            (*texels)[size_t(y) * size_t(width) + size_t(x)] = v;
        }
    }
}

// Adds the sun disk (Mitsuba's SunEmitter/SunSkyEmitter scheme, sky.h). Every point carries the same
// share of the disk's power; dividing by sin(theta) of the point turns it into radiance of the texel,
// whose solid angle is 2 pi^2 sin(theta) / (width height).
void rasterise_sun(const SunSkyParams& p, int width, int height, std::vector<RGB>* texels) {
    const RGB radiance = sun_radiance(p.sun.theta, p.turbidity) * p.sun_scale;
    const Vec3 n = sky_direction({p.sun.theta * p.stretch, p.sun.phi});
    Vec3 s, t;
    basis(n, &s, &t);
    const float cos_cone = std::cos(float(sun_angular_radius()) * p.sun_radius_scale);
    // About a thousand points per texel the scaled disk covers, at least 100 (Mitsuba's count).
    const size_t pixels = size_t(p.resolution) * size_t(p.resolution) / 2;
    const float covered = 0.5f * (1 - cos_cone);
    const size_t count = size_t(std::max(100.0f, float(pixels) * covered * 1000));
    const RGB share = radiance * float(double(sun_solid_angle()) * double(width) * double(height) /
                                       (2 * kPiD * kPiD * double(count)));
    for (size_t i = 0; i < count; ++i) {
        // A point uniform in the cone around +z, then turned to the sun.
        const float u = van_der_corput(uint32_t(i)), v = sobol_dim2(uint32_t(i));
        const float ct = (1 - u) + u * cos_cone, st = std::sqrt(std::max(0.0f, 1 - ct * ct));
        const float ph = float(2 * kPiD) * v;
        const Vec3 d = s * (std::cos(ph) * st) + t * (std::sin(ph) * st) + n * ct;
        const float sin_theta = std::sqrt(std::max(0.0f, 1 - d.y * d.y));
        const SkyAngles a = sky_angles(d);
        const int x = std::clamp(int(a.phi * width / (2 * kPiD)), 0, width - 1);
        const int y = std::clamp(int(a.theta * height / kPiD), 0, height - 1);
        (*texels)[size_t(y) * size_t(width) + size_t(x)] =
            (*texels)[size_t(y) * size_t(width) + size_t(x)] + share / std::max(1e-3f, sin_theta);
    }
}

}  // namespace

std::vector<RGB> sunsky_texels(const SunSkyParams& p) {
    check_params(p);
    const int width = p.resolution, height = p.resolution / 2;
    std::vector<RGB> texels(size_t(width) * size_t(height), RGB(0.0f));
    if (p.with_sky) rasterise_sky(p, width, height, &texels);
    if (p.with_sun && p.sun_radius_scale > 0) rasterise_sun(p, width, height, &texels);
    return texels;
}

std::shared_ptr<const EnvMap> make_sunsky_envmap(const SunSkyParams& p, const Transform& to_world) {
    return make_envmap(p.resolution, p.resolution / 2, sunsky_texels(p), to_world);
}

RGB sun_irradiance(const SunSkyParams& p) {
    return sun_radiance(p.sun.theta, p.turbidity) * (sun_solid_angle() * p.sun_scale);
}

Vec3 sun_travel_direction(const SunSkyParams& p, const Transform& to_world) {
    const Vec3 towards_sun = to_world.vector(sky_direction({p.sun.theta * p.stretch, p.sun.phi}));
    return -normalize(towards_sun);
}

}  // namespace iris
