// Light sources: area emitters on triangle meshes and on analytic spheres, point and spot lights, a
// directional light, and an environment (constant, or an equirectangular map). Lights are chosen in proportion to their power (luminance of their RGB power, in W).
// Area emitters radiate only on the side their surface normal points to (Mitsuba convention).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/math.h"
#include "libcommon/sampling.h"

namespace iris {

struct Scene;

enum class LightType : uint8_t { AreaMesh, AreaSphere, Point, Constant, Envmap, Spot, Directional };

// An equirectangular (latitude-longitude) environment map in Mitsuba 0.5's convention: in the map's
// local frame +y is up; the texel at (u, v) in [0,1)^2 (u along a row, v down the rows, row 0 at the
// top) is the radiance arriving from direction
//   d = (sin(phi) sin(theta), cos(theta), -cos(phi) sin(theta)),  phi = 2 pi u, theta = pi v,
// i.e. u = atan2(d.x, -d.z) / 2 pi (wrapped to [0,1)), v = acos(d.y) / pi. Radiance is piecewise
// constant per texel (nearest lookup) and sampled exactly in proportion to luminance x sin(theta) of
// the texel centre, so pdf and radiance agree texel by texel.
struct EnvMap {
    int width = 0, height = 0;
    std::vector<RGB> texels;           // W/(m^2 sr), scale applied; row-major, row 0 = theta 0
    Distribution1D rows;               // marginal over rows (weight: the row's sum)
    std::vector<Distribution1D> cols;  // per row: columns by luminance
    Transform to_world, to_local;      // map frame <-> world (directions only)
    RGB integral;                      // integral of the radiance over the sphere, W/m^2 (per channel)
};

// Builds an environment map from width x height texels (W/(m^2 sr)). Throws std::invalid_argument for a
// size of zero, a texel count that does not match, or a negative or non-finite texel. An all-black map
// is valid: it emits nothing and is never sampled.
std::shared_ptr<const EnvMap> make_envmap(int width, int height, std::vector<RGB> texels, const Transform& to_world);
// Radiance arriving from the world direction d (unit; pointing from the scene towards the sky).
RGB envmap_eval(const EnvMap& m, Vec3 d);
// Density per steradian with which envmap_sample produces d (0 where the map is black, or at a pole).
float envmap_pdf(const EnvMap& m, Vec3 d);
// A direction by the map's distribution; false for a black map (or a sample at a pole). *pdf is
// envmap_pdf(*d), bit for bit.
bool envmap_sample(const EnvMap& m, Vec2 u, Vec3* d, float* pdf);

// Mitsuba 0.5's spot light falloff for cos(angle to the axis): 1 inside beam_width, falling linearly in
// the angle to 0 at cutoff, 0 outside.
float spot_falloff(float cutoff, float beam_width, float cos_cutoff, float cos_theta);

struct Light {
    LightType type = LightType::AreaMesh;
    RGB radiance;          // area/constant: radiance in W/(m^2 sr); point/spot: intensity in W/sr;
                           // directional: irradiance in W/m^2 (on a surface facing it); envmap: unused
    Vec3 direction;        // Spot: unit axis of the cone; Directional: unit direction of travel (world)
    float cutoff = 0, beam_width = 0, cos_cutoff = 1;  // Spot: half-angles in radians, cos(cutoff)
    std::shared_ptr<const EnvMap> envmap;              // Envmap
    uint32_t shape = 0;    // AreaMesh: index into Scene::meshes; AreaSphere: index into Scene::spheres
    Vec3 position;         // Point/Spot: position
    float area = 0;        // AreaMesh / AreaSphere: total surface area (m^2, world units squared)
    Distribution1D triangles;  // AreaMesh: triangle selection in proportion to area
    // AreaMesh: per triangle, computed once by lights_prepare, what a light sample reads of it in one
    // record: its unit normal (flip_normals applied; zero for a zero-area triangle; from the double
    // cross product), and what the cheap test needs that keeps far triangles on area sampling
    // (lights.cpp, maybe_near): its centroid, the centroid's largest distance to a vertex (world units),
    // and its area over the solid-angle sampler's threshold (world units squared per sr).
    struct Triangle {
        Vec3 normal;
        Vec3 centre;
        float radius = 0;
        float area_over_min = 0;
    };
    std::vector<Triangle> triangle_info;
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
    uint32_t prim = 0;  // mesh lights: the triangle the point lies on (light_pdf's `prim`)
};

// Emitted radiance of an area/constant light leaving its surface point with normal n in direction w
// (w points away from the light). Zero on the back side.
RGB light_emitted(const Light& l, Vec3 n, Vec3 w);

// Total emitted power in W (RGB), used for light selection and photon flux. One-sided Lambertian area
// emitters: pi A L (mesh), pi 4 pi r^2 L (sphere); point: 4 pi I; spot: I times the falloff's solid
// angle; constant environment: pi R^2 4 pi L; envmap: pi R^2 times the map's integral; directional:
// pi R^2 E; with R the radius of the scene's bounding sphere (from scene.bounds_*, or from the meshes and spheres
// when the bounds are unset).
RGB light_power(const Scene& scene, const Light& l);

// Radius R of the scene's bounding sphere (scene.bounds_* if set, else from the geometry; 0 without
// any), and the area pi R^2 of the disk that the distant lights' (environment, directional) light paths
// start on (emission.h): their power is the flux through it, and connections weigh their paths by it.
double scene_radius(const Scene& scene);
inline double bounding_disk_area(const Scene& scene) {
    const double r = scene_radius(scene);
    return 3.14159265358979323846 * r * r;
}

// Builds per-light tables (triangle CDFs, areas), scene.environment_light, and the selection table
// scene.light_selection in proportion to luminance(power) * sampling_weight (zero power: never chosen).
// Throws std::runtime_error for a shape index out of range, non-finite power, or a second environment.
void lights_prepare(Scene& scene);

// Chooses a light (by power) and a point on it as seen from `ref`. u_sel selects the light (and, rescaled,
// a mesh light's triangle), u the point. Returns false (and a zeroed *s) when the sample carries no
// light: no light with power, the point faces away from ref (emitters radiate on their normal side
// only), coincides with ref, or its density would overflow a float. Never yields NaN or Inf.
// Sphere lights seen from outside are sampled uniformly in the cone they subtend; from inside (or on
// the surface) uniformly by area. Mesh lights: a triangle in proportion to its area, then a point on it
// uniformly in solid angle where it subtends at least kSolidAngleSampling (near the light), else
// uniformly by area. For the environment, p and n are zero and dist is infinite.
bool sample_light(const Scene& scene, Vec3 ref, float u_sel, Vec2 u, LightSample* s);

// Least solid angle (sr) of a mesh light's triangle, seen from the reference point, for which
// sample_light samples it uniformly in solid angle rather than by area. On the Cornell box lit by a
// ceiling panel (scenes/cbox/panel_box.xml), 0.01 and 0.1 left the same variance (1 % apart) and 0.1
// cost less time, 0.3 and 1.0 gained less; the box's usual small lamp subtends less than 0.1 sr
// everywhere, so it keeps area sampling (docs/BENCHMARKS.md, lights.md).
constexpr double kSolidAngleSampling = 0.1;

// Density per steradian (including selection) with which sample_light would produce the point `p`
// with normal `n` (the emitter's geometric normal, flipped as Mesh/Sphere::flip_normals says) on light
// `light`, seen from `ref` (for MIS when a BSDF-sampled ray hits a light); for a mesh light `prim` is
// the triangle p lies on (SurfaceHit::prim; ignored for other lights). It equals the pdf that
// sample_light reports for that point, bit for bit, and is 0 wherever sample_light rejects the point
// itself (its back side, distance 0, an overflowing density). (A solid-angle sample that rounding
// leaves without a direction or a point -- a measure-zero set -- is rejected by sample_light only.)
// For the environment, p and n are ignored and wi is the direction. For a point light (which no ray
// can hit) it returns the selection probability, the mass of the delta, as LightSample::pdf does.
float light_pdf(const Scene& scene, uint32_t light, uint32_t prim, Vec3 ref, Vec3 p, Vec3 n, Vec3 wi);

// Probability that sample_light picks `light`.
float light_selection_pmf(const Scene& scene, uint32_t light);

}  // namespace iris
