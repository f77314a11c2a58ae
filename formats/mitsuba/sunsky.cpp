// <emitter> plugins "sky", "sun" and "sunsky" (registered in emitters.cpp's table): Mitsuba 0.5's
// daylight, read with its parameter names and defaults and rasterised by libcommon/sky.h into one
// environment map (or, for a sun of sunRadiusScale 0, a directional light). Mitsuba checks the sky's
// turbidity, stretch and albedo ranges and refuses a sun below the horizon; iris checks those for all
// three plugins, and the date and place too (Mitsuba takes a month 13 as the next January).
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "formats/mitsuba/builder.h"
#include "libcommon/sky.h"

namespace iris::mitsuba {
namespace {

int line_of(SceneBuilder& b, Plugin& e, const char* name) {
    Prop* p = b.find(e, name);
    return p ? p->line : e.line;
}

std::string num(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

[[noreturn]] void out_of_range(SceneBuilder& b, Plugin& e, const char* name, double v, double lo, double hi) {
    fail(*e.src, line_of(b, e, name),
         e.what() + ": " + name + " " + num(v) + " is outside [" + num(lo) + ", " + num(hi) + "]");
}

// A <float> (or <integer>) parameter that must lie in [lo, hi].
double ranged(SceneBuilder& b, Plugin& e, const char* name, double def, double lo, double hi) {
    const double v = b.get_float(e, name, float(def));
    if (!(v >= lo && v <= hi)) out_of_range(b, e, name, v, lo, hi);
    return v;
}

int ranged_int(SceneBuilder& b, Plugin& e, const char* name, int def, int lo, int hi) {
    const int v = b.get_int(e, name, def);
    if (v < lo || v > hi) out_of_range(b, e, name, v, lo, hi);
    return v;
}

bool leap_year(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

// The sun's direction in the emitter's own frame, before `stretch` (Mitsuba's computeSunCoordinates):
// either sunDirection (world space, towards the sun) taken back through toWorld, or the position for
// the date, local time and place: latitude in degrees north, longitude in degrees east, timezone in
// hours ahead of UTC, the time of day in hours, minutes and seconds of local time.
SkyAngles read_sun(SceneBuilder& b, Plugin& e, const Transform& to_world) {
    if (std::optional<Vec3> dir = b.get_point(e, "sunDirection")) {
        for (const char* other : {"latitude", "longitude", "timezone", "day"})
            if (b.find(e, other))
                fail(*e.src, line_of(b, e, other),
                     e.what() + ": give either sunDirection or the date, time and place, not both");
        const Vec3 local = to_world.inverse().vector(*dir);
        const float len = length(local);
        if (!(len > 0) || !std::isfinite(len))
            fail(*e.src, line_of(b, e, "sunDirection"), e.what() + ": sunDirection gives no direction");
        return sky_angles(local / len);
    }
    SunPlace place;
    place.latitude = ranged(b, e, "latitude", place.latitude, -90, 90);
    place.longitude = ranged(b, e, "longitude", place.longitude, -360, 360);
    place.timezone = ranged(b, e, "timezone", place.timezone, -24, 24);
    SunDateTime when;
    when.year = ranged_int(b, e, "year", when.year, -4000, 10000);
    when.month = ranged_int(b, e, "month", when.month, 1, 12);
    static const int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    const int days = kDays[when.month - 1] + (when.month == 2 && leap_year(when.year) ? 1 : 0);
    when.day = ranged_int(b, e, "day", when.day, 1, days);
    when.hour = ranged(b, e, "hour", when.hour, 0, 24);
    when.minute = ranged(b, e, "minute", when.minute, 0, 60);
    when.second = ranged(b, e, "second", when.second, 0, 60);
    return sun_position(when, place);
}

// What the three plugins share: toWorld, the sun, turbidity, stretch and resolution.
struct Common {
    Transform to_world;
    SunSkyParams p;
};

Common read_common(SceneBuilder& b, Plugin& e) {
    Common c;
    c.to_world = b.get_transform(e, "toWorld").value_or(Transform());
    if (!(std::abs(c.to_world.determinant3x3()) > 0))
        fail(*e.src, line_of(b, e, "toWorld"), e.what() + ": toWorld is singular");
    c.p.sun = read_sun(b, e, c.to_world);
    c.p.turbidity = ranged(b, e, "turbidity", 3.0, 1, 10);
    c.p.stretch = ranged(b, e, "stretch", 1.0, 1, 2);
    c.p.resolution = ranged_int(b, e, "resolution", 512, 2, 16384);
    if (c.p.sun.theta > 0.5 * 3.14159265358979323846)
        fail(*e.src, e.line,
             e.what() + ": the sun is below the horizon (zenith angle " +
                 num(c.p.sun.theta * 180 / 3.14159265358979323846) +
                 " degrees); Mitsuba's sky model needs it above");
    return c;
}

float read_scale(SceneBuilder& b, Plugin& e, const char* name, float def) {
    const float v = b.get_float(e, name, def);
    if (!(v >= 0) || !std::isfinite(v)) fail(*e.src, line_of(b, e, name), e.what() + ": " + name + " must be finite and >= 0");
    return v;
}

void read_sky_look(SceneBuilder& b, Plugin& e, SunSkyParams* p) {
    p->albedo = b.get_spectrum(e, "albedo", RGB(0.2f));  // the sky plugin's default (its docs say 0.15)
    for (int i = 0; i < 3; ++i)
        if (!(p->albedo[i] >= 0 && p->albedo[i] <= 1))
            fail(*e.src, line_of(b, e, "albedo"), e.what() + ": albedo must be in [0, 1]");
    p->extend = b.get_bool(e, "extend", false);
}

// The map, or the libcommon check that refused it, as a message at the emitter.
void set_envmap(Plugin& e, const SunSkyParams& p, const Transform& to_world, Light* l) {
    l->type = LightType::Envmap;
    try {
        l->envmap = make_sunsky_envmap(p, to_world);
    } catch (const std::invalid_argument& ex) {
        fail(*e.src, e.line, e.what() + ": " + ex.what());
    }
}

// With sunRadiusScale 0 the sun is a directional light beside the map (Mitsuba's sun and sunsky both
// make one); for "sunsky" it is added here and the map holds the sky.
Light sun_directional(SceneBuilder& b, Plugin& e, const SunSkyParams& p, const Transform& to_world) {
    Light d;
    d.type = LightType::Directional;
    d.direction = sun_travel_direction(p, to_world);
    d.radiance = sun_irradiance(p);  // W/m^2
    d.sampling_weight = b.get_float(e, "samplingWeight", 1.0f);
    return d;
}

}  // namespace

void sky_emitter(SceneBuilder& b, Plugin& e, Light* l) {
    Common c = read_common(b, e);
    c.p.with_sun = false;
    c.p.sky_scale = read_scale(b, e, "scale", 1.0f);
    read_sky_look(b, e, &c.p);
    set_envmap(e, c.p, c.to_world, l);
}

void sun_emitter(SceneBuilder& b, Plugin& e, Light* l) {
    Common c = read_common(b, e);
    c.p.with_sky = false;
    c.p.sun_scale = read_scale(b, e, "scale", 1.0f);
    c.p.sun_radius_scale = read_scale(b, e, "sunRadiusScale", 1.0f);
    if (c.p.sun_radius_scale == 0) *l = sun_directional(b, e, c.p, c.to_world);
    else set_envmap(e, c.p, c.to_world, l);
}

void sunsky_emitter(SceneBuilder& b, Plugin& e, Light* l) {
    Common c = read_common(b, e);
    const float scale = read_scale(b, e, "scale", 1.0f);
    c.p.sun_scale = read_scale(b, e, "sunScale", scale);
    c.p.sky_scale = read_scale(b, e, "skyScale", scale);
    c.p.sun_radius_scale = read_scale(b, e, "sunRadiusScale", 1.0f);
    read_sky_look(b, e, &c.p);
    if (c.p.sun_radius_scale == 0) {
        c.p.with_sun = false;
        b.scene.lights.push_back(sun_directional(b, e, c.p, c.to_world));
    }
    set_envmap(e, c.p, c.to_world, l);
}

}  // namespace iris::mitsuba
