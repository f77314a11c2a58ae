// Sampling light *leaving* the lights, for photon tracing: a light chosen in proportion to its power,
// a point on it and a direction. The photon's flux is Phi_light / p_select (divide by the number of
// emitted paths N to get the per-photon flux of DESIGN 4.5).
#pragma once

#include "libcommon/bsdf.h"
#include "libcommon/color.h"
#include "libcommon/math.h"
#include "libcommon/rng.h"
#include "libcommon/scene.h"

namespace iris {

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

// One bounce of a light path (a photon, or a light-traced caustic) at `hit`, reached from w_back (world,
// pointing back towards the light), at path depth `depth`: samples the BSDF in importance mode with the
// next three numbers of rng, refuses directions that cross the true surface on the side the shading
// normal claims, applies the adjoint BSDF's shading-normal correction (Veach 1997, 5.3) and, from
// rr_depth on, Russian roulette on the ratio of new to old power (keeps powers even). On success updates
// *beta and sets *wo_world and *delta (a Dirac lobe was sampled); false: the path ends.
bool scatter_light_path(const SurfaceHit& hit, const Bsdf& bsdf, Vec3 w_back, int depth, int rr_depth, Rng& rng,
                        RGB* beta, Vec3* wo_world, bool* delta);

}  // namespace iris
