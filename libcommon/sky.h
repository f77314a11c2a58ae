// Daylight as Mitsuba 0.5 models it in its RGB build (SPECTRUM_SAMPLES = 3): the position of the sun
// for a date, time and place; the Hosek-Wilkie sky (RGB coefficient version); the Preetham sun disk;
// and the rasterisation of both into one latitude-longitude environment map (lights.h's EnvMap), which
// is what Mitsuba's `sky`, `sun` and `sunsky` emitters render with. The reader that turns the XML
// parameters into a SunSkyParams is formats/mitsuba/emitters.cpp; docs/mitsuba-parts/sky.md lists the
// parameters and the known differences.
//
// Frames and angles. The map's local frame is Mitsuba's: +y is up (the zenith); a direction of zenith
// angle theta and azimuth phi is (sin phi sin theta, cos theta, -cos phi sin theta), so phi = 0 looks
// along -z and phi = pi/2 along +x. The solar position's azimuth is measured from north towards east,
// and Mitsuba uses it unchanged as phi: north is -z and east is +x in the map's frame (before toWorld).
#pragma once

#include <memory>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/lights.h"
#include "libcommon/math.h"

namespace iris {

// A local civil date and time.
struct SunDateTime {
    int year = 2010, month = 7, day = 10;          // Mitsuba's defaults
    double hour = 15, minute = 0, second = 0;      // local time, 24-hour clock
};
// The observer's place: degrees north, degrees east, and the time zone's offset from UTC in hours.
struct SunPlace {
    double latitude = 35.6894, longitude = 139.6917, timezone = 9;  // Mitsuba's default: Tokyo
};
// A direction in the sky: zenith angle theta (0 = straight up) and azimuth phi, both in radians, phi in
// [0, 2 pi).
struct SkyAngles {
    double theta = 0, phi = 0;
};

// The sun's direction seen from `place` at local time `when`, by the algorithm of Blanco-Muriel,
// Alarcon-Padilla, Lopez-Moratalla and Lara-Coira, "Computing the solar vector", Solar Energy 70(5),
// 2001 (the one Mitsuba 0.5 uses): geometric, with the parallax correction, without refraction;
// stated accuracy 0.5 arcminute for 1999-2015. theta is the zenith angle, phi the azimuth from north
// towards east. Dates are taken as given (no range check: that is the reader's job).
SkyAngles sun_position(const SunDateTime& when, const SunPlace& place);

// Map-frame direction of (theta, phi), and back (phi wrapped to [0, 2 pi)).
Vec3 sky_direction(SkyAngles a);
SkyAngles sky_angles(Vec3 d);

// The Hosek-Wilkie sky model (Hosek and Wilkie, "An Analytic Model for Full Spectral Sky-Dome
// Radiance", SIGGRAPH 2012) with its RGB coefficient tables, one model per channel as Mitsuba 0.5 sets
// it up: channel c uses the ground albedo albedo[c]. radiance() is in W/(m^2 sr), Mitsuba's scaling:
// the model's RGB value divided by 106.856980 (the sum of the CIE y-bar samples).
class HosekWilkieSky {
public:
    // turbidity in [1, 10], albedo channels in [0, 1], sun_zenith in [0, pi/2] radians; throws
    // std::invalid_argument otherwise.
    HosekWilkieSky(double turbidity, RGB albedo, double sun_zenith);
    // Radiance from a direction of zenith angle theta (< pi/2: the model is not defined at or below
    // the horizon) at angle gamma from the sun, radians. Unclamped: Mitsuba clamps negatives after.
    RGB radiance(double theta, double gamma) const;

private:
    double coef_[3][9];  // per channel, the model's A..I at this turbidity, albedo and elevation
    double scale_[3];    // per channel, the radiance scale (W/(m^2 sr), already divided by 106.856980)
};

// Preetham's sun ("A Practical Analytic Model for Daylight", SIGGRAPH 1999): the extraterrestrial
// solar spectrum attenuated by Rayleigh and aerosol scattering and ozone, mixed-gas and water-vapour
// absorption along the air mass of a sun at zenith angle `sun_zenith` (radians, <= pi/2), for a
// turbidity in [1, 10]. sun_spectrum fills its 91 samples (350..800 nm, 5 nm apart; W/(m^2 sr nm)) as
// Mitsuba evaluates them; sun_radiance converts them to linear RGB the way Mitsuba's RGB build does
// (CIE 1931 integration over 360..830 nm divided by the integral of y-bar, Rec. 709; negatives clamped).
void sun_spectrum(double sun_zenith, double turbidity, std::vector<float>* wavelengths, std::vector<float>* values);
RGB sun_radiance(double sun_zenith, double turbidity);

// Angular radius of the sun's disk in radians: Mitsuba's SUN_APP_RADIUS of 0.5358 degrees is a
// diameter, halved (0.2679 degrees). Its solid angle, 2 pi (1 - cos), is what the disk's radiance is
// multiplied by for its power, computed in single precision as Mitsuba's build does.
double sun_angular_radius();
float sun_solid_angle();

// Everything a `sky`, `sun` or `sunsky` emitter computes from, after the reader has checked the ranges.
struct SunSkyParams {
    bool with_sky = true, with_sun = true;
    SkyAngles sun;            // in the map's frame, before `stretch`
    double turbidity = 3;     // [1, 10]
    RGB albedo{0.2f};         // ground albedo per channel, [0, 1] (Mitsuba's sky plugin default: 0.2)
    double stretch = 1;       // [1, 2]: the sky's zenith angles are stretched by it towards the nadir
    bool extend = false;      // continue the sky below the horizon, fading out (Mitsuba's `extend`)
    int resolution = 512;     // map width; the height is resolution / 2
    float sky_scale = 1, sun_scale = 1;
    float sun_radius_scale = 1;  // > 0: the disk's radius times this, power kept (0: see sun_directional)
};

// The map's texels (resolution x resolution / 2, row 0 at the zenith, W/(m^2 sr)): the sky sampled
// at texel centres, then the sun disk added by Mitsuba's scheme -- a fixed (0,2)-sequence of points
// spread uniformly over the (radius-scaled) cone of the disk, each depositing power / count into the
// texel it falls in, divided by that texel's solid angle at the point's sin(theta). The disk is drawn
// whole even where it dips below the horizon. Throws std::invalid_argument for out-of-range params
// (the reader reports them first, with their lines).
std::vector<RGB> sunsky_texels(const SunSkyParams& p);

// The environment light of the params (texels as above, oriented by to_world).
std::shared_ptr<const EnvMap> make_sunsky_envmap(const SunSkyParams& p, const Transform& to_world);

// With sun_radius_scale == 0 Mitsuba replaces the disk by a directional light: its irradiance (the
// disk's radiance times its solid angle, times sun_scale, W/m^2) and world direction of travel.
RGB sun_irradiance(const SunSkyParams& p);
Vec3 sun_travel_direction(const SunSkyParams& p, const Transform& to_world);

}  // namespace iris
