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

// Total emitted power in W (RGB), used for light selection and photon flux.
RGB light_power(const Scene& scene, const Light& l);

// Builds per-light tables (triangle CDFs, areas) and the scene's power-proportional selection table.
void lights_prepare(Scene& scene);

// Chooses a light (by power) and a point on it as seen from `ref`. u_sel selects the light, u the point.
bool sample_light(const Scene& scene, Vec3 ref, float u_sel, Vec2 u, LightSample* s);

// Density per steradian (including selection) with which sample_light would produce the point `p`
// with normal `n` on light `light`, seen from `ref` (for MIS when a BSDF-sampled ray hits a light).
// For the environment, p and n are ignored and wi is the direction.
float light_pdf(const Scene& scene, uint32_t light, Vec3 ref, Vec3 p, Vec3 n, Vec3 wi);

// Probability that sample_light picks `light`.
float light_selection_pmf(const Scene& scene, uint32_t light);

}  // namespace iris
