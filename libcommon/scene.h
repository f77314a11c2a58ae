// The in-memory scene: geometry in flat arrays, BSDFs, lights, the camera and film settings, and the
// Embree acceleration structure over it. Knows no file format: formats/scene_xml.h fills it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "libcommon/bsdf.h"
#include "libcommon/camera.h"
#include "libcommon/color.h"
#include "libcommon/lights.h"
#include "libcommon/math.h"
#include "libcommon/texture.h"

namespace iris {

// Triangle mesh in world space.
struct Mesh {
    std::string name;              // for messages: file name or shape id
    std::vector<Vec3> positions;   // world space
    std::vector<Vec3> normals;     // per-vertex shading normals (world space), empty = flat shading
    std::vector<Vec2> uvs;         // per-vertex texture coordinates (u, v) from the mesh file, empty = none
    std::vector<uint32_t> indices; // 3 per triangle
    uint32_t bsdf = 0;             // index into Scene::bsdfs
    int32_t light = -1;            // index into Scene::lights if the mesh is an area emitter
    bool flip_normals = false;     // Mitsuba `flipNormals`
    uint32_t triangle_count() const { return uint32_t(indices.size() / 3); }
};

// Analytic sphere (Mitsuba `sphere`); the normal points outwards unless flip_normals.
struct Sphere {
    Vec3 center;
    float radius = 1;
    uint32_t bsdf = 0;
    int32_t light = -1;
    bool flip_normals = false;
    // The object frame's unit axes in world space (toWorld's rotation): Mitsuba's spherical uv
    // parameterization is taken in it (phi about axis_z from axis_x, theta from axis_z).
    Vec3 axis_x{1, 0, 0}, axis_y{0, 1, 0}, axis_z{0, 0, 1};
};

enum class FilterType : uint8_t { Box, Gaussian };

struct FilmSettings {
    int width = 768, height = 576;
    FilterType filter = FilterType::Gaussian;
    float filter_stddev = 0.5f;  // pixels (Gaussian)
    float filter_radius = 2.0f;  // pixels (Gaussian: 4 stddev as Mitsuba; box: 0.5)
};

// Defaults a render takes from the scene file (Mitsuba's <integrator> and <sampler>).
struct RenderDefaults {
    int max_depth = -1;  // Mitsuba meaning: longest path in edges, -1 = unlimited
    int rr_depth = 5;    // Russian roulette starts at this depth
    int spp = 16;        // <sampler>'s sampleCount
};

// What kind of object an Embree geometry ID refers to.
struct GeomRef {
    enum Kind : uint8_t { MeshKind, SphereKind } kind;
    uint32_t index;
};

// A ray with parametric extent [tmin, tmax].
struct Ray {
    Vec3 o, d;
    float tmin = 0, tmax = kInf;
};

// The primary ray through film position (fx, fy) of a prepared camera (camera_prepare), clipped to the
// camera's near/far planes as Mitsuba does: distances along the view axis, divided by the cosine.
inline Ray camera_ray(const Camera& c, float fx, float fy, int width, int height) {
    Ray ray;
    ray.o = c.origin;
    ray.d = camera_direction(c, fx, fy, width, height);
    const float cos_fwd = dot(ray.d, c.forward);
    ray.tmin = c.near_clip / cos_fwd;
    ray.tmax = c.far_clip / cos_fwd;
    return ray;
}

// Everything the integrator needs to know about a surface hit.
struct SurfaceHit {
    Vec3 p;          // position, recomputed from the primitive (not o + t d) for precision
    Vec3 ng;         // geometric normal (unit, on the side the shape's normal points)
    Vec3 ns;         // shading normal (unit), same hemisphere as ng after the loader's checks
    Frame frame;     // shading frame around ns
    float t = 0;
    uint32_t bsdf = 0;
    int32_t light = -1;
    uint32_t geom = 0, prim = 0;
    // Largest absolute coordinate of the primitive that was hit (its vertices; a sphere's centre plus
    // radius): the scale of the rounding error in p, which offset_ray_origin must step over.
    float magnitude = 0;
    // Surface texture coordinates (Mitsuba's its.uv), computed only where the shape's BSDF is textured
    // (elsewhere (0, 0): nothing reads them, and untextured scenes pay nothing): a mesh's per-vertex
    // uvs interpolated with the barycentrics (for a mesh without uvs the barycentrics of its vertices
    // 1 and 2, as in Mitsuba), a sphere's (phi / 2 pi, theta / pi) in its object frame.
    Vec2 uv;
};

class Accel;  // Embree wrapper, defined in accel.h

struct Scene {
    std::string source;             // the file it came from, for messages and provenance
    std::string fingerprint;        // hex digest of the scene file and every mesh it loads
    std::vector<Mesh> meshes;
    std::vector<Sphere> spheres;
    std::vector<Bsdf> bsdfs;
    std::vector<Texture> textures;  // Bsdf::tex_* index these; one per distinct texture of the file
    std::vector<Light> lights;
    Distribution1D light_selection;  // in proportion to power * sampling_weight
    int environment_light = -1;      // index of the constant environment light, if any
    Camera camera;
    FilmSettings film;
    RenderDefaults defaults;
    Vec3 bounds_min{kInf}, bounds_max{-kInf};
    std::vector<GeomRef> geoms;     // Embree geometry ID -> object
    std::shared_ptr<Accel> accel;

    Scene();
    ~Scene();
    Scene(Scene&&) noexcept;
    Scene& operator=(Scene&&) noexcept;

    // Computes bounds, builds lights and the Embree BVH. Call after the loader has filled the arrays.
    void finalize();

    // Closest hit along the ray; false on a miss.
    bool intersect(const Ray& ray, SurfaceHit* hit) const;
    // True if anything blocks the segment between two points (both already offset off their surfaces).
    bool occluded(Vec3 from, Vec3 to) const;
    // True if anything blocks the ray within [tmin, tmax].
    bool occluded(const Ray& ray) const;

    // Scale of the scene (largest absolute bounding-box coordinate), for relative epsilons.
    float scale() const { return std::max(max_abs_component(bounds_min), max_abs_component(bounds_max)); }
};

// Moves p off its surface along the geometric normal ng, to the side of direction w, by a few ULPs of
// the magnitude of the coordinates p was computed from: max(|p|_inf, magnitude), where `magnitude` is
// SurfaceHit::magnitude for a hit (0 = p's own coordinates only). Purely relative, so that rays
// leaving the surface never hit it again and never start visibly off it, at any scene scale and
// position (tests/stress/test_ray_offsets.cpp).
Vec3 offset_ray_origin(Vec3 p, Vec3 ng, Vec3 w, float magnitude = 0.0f);

// Whether some shape has a Dirac lobe (bsdf_has_delta_lobe): the only surfaces where light can take a
// specular bounce (a caustic).
bool has_specular_surfaces(const Scene& scene);

// Mitsuba's texture coordinates (SurfaceHit::uv) of triangle `prim` of a mesh at Embree's barycentrics
// (u, v), and of a sphere at the unit outward direction n (world space) from its centre.
Vec2 mesh_uv(const Mesh& m, uint32_t prim, float u, float v);
Vec2 sphere_uv(const Sphere& s, Vec3 n);

// The BSDF at a surface hit: scene.bsdfs[hit.bsdf] with its textured parameters evaluated at hit.uv.
// An untextured BSDF (the common case; a bump map alone does not count, Scene::intersect applies it to
// the hit's frame) is returned by reference, at the cost of one flag test; a
// textured one is copied into *scratch, its textures looked up and its reflectance-dependent sampling
// weight refreshed (bsdf_refresh_weights), and *scratch is returned. Every BSDF query at one vertex
// (eval, pdf, sample, guiding shares) must use the same returned BSDF.
// A Mixture's textured parts are resolved into scratch->parts and the copy's part[] points there (so a
// BsdfScratch must not be copied while the returned BSDF is in use); the loader refuses a textured
// Mixture inside a Mixture, so one level of parts suffices.
struct BsdfScratch {
    Bsdf bsdf;
    Bsdf parts[kMaxBsdfParts];
};
const Bsdf& resolve_textured_bsdf(const Scene& scene, const Bsdf& b, Vec2 uv, BsdfScratch* scratch);
inline const Bsdf& scene_bsdf_at(const Scene& scene, const SurfaceHit& hit, BsdfScratch* scratch) {
    const Bsdf& b = scene.bsdfs[hit.bsdf];
    if (!b.textured_params) return b;
    return resolve_textured_bsdf(scene, b, hit.uv, scratch);
}

// A ray leaving a surface hit in direction w.
inline Ray spawn_ray(const SurfaceHit& h, Vec3 w) {
    Ray r;
    r.o = offset_ray_origin(h.p, h.ng, w, h.magnitude);
    r.d = w;
    return r;
}

}  // namespace iris
