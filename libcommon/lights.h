// Light sources: area emitters on triangle meshes and on analytic spheres, point lights, and a constant
// environment. Lights are chosen in proportion to their power (luminance of their RGB power, in W).
// Area emitters radiate only on the side their surface normal points to (Mitsuba convention).
#pragma once

#include <cstdint>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/math.h"
#include "libcommon/sampling.h"

namespace iris {

struct Scene;

enum class LightType : uint8_t { AreaMesh, AreaSphere, Point, Constant };

struct Light {
    LightType type = LightType::AreaMesh;
    RGB radiance;          // area/constant: radiance in W/(m^2 sr); point: intensity in W/sr
    uint32_t shape = 0;    // AreaMesh: index into Scene::meshes; AreaSphere: index into Scene::spheres
    Vec3 position;         // Point: position
    float area = 0;        // AreaMesh / AreaSphere: total surface area (m^2, world units squared)
    Distribution1D triangles;  // AreaMesh: triangle selection in proportion to area
    float sampling_weight = 1; // Mitsuba's `samplingWeight` (multiplies the selection weight)
};

// A point on a light seen from a reference point.
struct LightSample {
    Vec3 p;           // point on the light (unused for the environment)
    Vec3 n;           // its surface normal (zero for point lights)
    Vec3 wi;          // unit direction from the reference point towards the light
    float dist = 0;   // distance to p (infinity for the environment)
    RGB radiance;     // emitted radiance towards the reference point (intensity/dist^2 for points)
    float pdf = 0;    // per steradian at the reference point, *including* the light-selection probability;
                      // for point lights, the selection probability (a delta in direction)
    bool delta = false;
    uint32_t light = 0;
};

// Emitted radiance of an area/constant light leaving its surface point with normal n in direction w
// (w points away from the light). Zero on the back side.
RGB light_emitted(const Light& l, Vec3 n, Vec3 w);

// Total emitted power in W (RGB), used for light selection and photon flux. One-sided Lambertian area
// emitters: pi A L (mesh), pi 4 pi r^2 L (sphere); point: 4 pi I; constant environment: pi R^2 4 pi L
// with R the radius of the scene's bounding sphere (from scene.bounds_*, or from the meshes and spheres
// when the bounds are unset).
RGB light_power(const Scene& scene, const Light& l);

// Builds per-light tables (triangle CDFs, areas), scene.environment_light, and the selection table
// scene.light_selection in proportion to luminance(power) * sampling_weight (zero power: never chosen).
// Throws std::runtime_error for a shape index out of range, non-finite power, or a second environment.
void lights_prepare(Scene& scene);

// Chooses a light (by power) and a point on it as seen from `ref`. u_sel selects the light (and, rescaled,
// a mesh light's triangle), u the point. Returns false (and a zeroed *s) when the sample carries no
// light: no light with power, the point faces away from ref (emitters radiate on their normal side
// only), coincides with ref, or its density would overflow a float. Never yields NaN or Inf.
// Sphere lights seen from outside are sampled uniformly in the cone they subtend; from inside (or on
// the surface) uniformly by area. For the environment, p and n are zero and dist is infinite.
bool sample_light(const Scene& scene, Vec3 ref, float u_sel, Vec2 u, LightSample* s);

// Density per steradian (including selection) with which sample_light would produce the point `p`
// with normal `n` (the emitter's geometric normal, flipped as Mesh/Sphere::flip_normals says) on light
// `light`, seen from `ref` (for MIS when a BSDF-sampled ray hits a light). It equals the pdf that
// sample_light reports for that point, bit for bit, and is 0 wherever sample_light would reject.
// For the environment, p and n are ignored and wi is the direction. For a point light (which no ray
// can hit) it returns the selection probability, the mass of the delta, as LightSample::pdf does.
float light_pdf(const Scene& scene, uint32_t light, Vec3 ref, Vec3 p, Vec3 n, Vec3 wi);

// Probability that sample_light picks `light`.
float light_selection_pmf(const Scene& scene, uint32_t light);

}  // namespace iris
