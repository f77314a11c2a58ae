// Sampling light *leaving* the lights, for photon tracing: a light chosen in proportion to its power,
// a point on it and a direction. The photon's flux is Phi_light / p_select (divide by the number of
// emitted paths N to get the per-photon flux of DESIGN 4.5).
#pragma once

#include "libcommon/color.h"
#include "libcommon/math.h"

namespace iris {

struct Scene;

struct EmissionSample {
    Vec3 p;         // origin of the photon (on the light's surface; for the environment, outside the scene)
    Vec3 n;         // surface normal at p (zero for point lights and the environment)
    Vec3 d;         // unit direction of travel
    RGB flux;       // W: Phi_light / p_select(light)
    uint32_t light = 0;
};

// u_sel chooses the light, u_pos a point on it, u_dir a direction. False if the scene has no light
// with power.
bool sample_emission(const Scene& scene, float u_sel, Vec2 u_pos, Vec2 u_dir, EmissionSample* s);

}  // namespace iris
