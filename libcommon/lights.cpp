// Light sampling (next event estimation) and the matching densities for MIS.
//
// The contract that matters most (DESIGN.md §4.1): light_pdf(...) returns exactly the density with
// which sample_light(...) produces that point. Both therefore go through the same helpers below
// (see_area_point, view_sphere), in the same precision and with the same rejection rules, so the two
// agree bit for bit and not merely "up to rounding".
//
// Rejections (sample_light returns false, light_pdf returns 0), all for the same reasons:
//   - the point faces away from the reference point (emitters radiate on their normal side only),
//   - the point coincides with the reference point (distance 0),
//   - the solid-angle density would overflow a float (a grazing or absurdly distant emitter: its
//     contribution L cos / pdf is zero to float precision anyway).
// Geometry that decides these is evaluated in double: distances and cosines are computed once from
// float inputs, and double keeps d^2 / cos and 1 - cos(theta_max) accurate for tiny or far emitters.
#include "libcommon/lights.h"
#include "libcommon/mutation.h"

#include <algorithm>
#include <cfloat>
#include <stdexcept>
#include <string>

#include "libcommon/scene.h"

namespace iris {

namespace {

constexpr double kPiD = 3.14159265358979323846;

struct Vec3d {
    double x = 0, y = 0, z = 0;
};
inline Vec3d to_d(Vec3 v) { return {v.x, v.y, v.z}; }
inline Vec3 to_f(Vec3d v) { return Vec3(float(v.x), float(v.y), float(v.z)); }
inline Vec3d sub(Vec3d a, Vec3d b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3d add(Vec3d a, Vec3d b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline double dot_d(Vec3d a, Vec3d b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d scale(Vec3d a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3d cross_d(Vec3d a, Vec3d b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Largest density we report: beyond it a float pdf would be infinite.
constexpr double kMaxPdf = double(FLT_MAX);

// A point on an area emitter as seen from the reference point.
struct Seen {
    Vec3 wi;          // unit direction ref -> p
    float dist = 0;   // |p - ref|
    double d2 = 0;    // |p - ref|^2
    double cos_light = 0;  // cosine at the light between its normal and the direction back to ref
    bool ok = false;  // p is distinct from ref and faces it
};

Seen see_area_point(Vec3 ref, Vec3 p, Vec3 n) {
    Seen s;
    Vec3d d = sub(to_d(p), to_d(ref));  // exact: the difference of two floats fits a double
    s.d2 = dot_d(d, d);
    if (!(s.d2 > 0) || !std::isfinite(s.d2)) return s;
    double dist = std::sqrt(s.d2);
    Vec3d w = scale(d, 1.0 / dist);
    s.wi = to_f(w);
    s.dist = float(dist);
    s.cos_light = -dot_d(to_d(n), w);
    s.ok = s.cos_light > 0 && std::isfinite(s.dist) && s.dist > 0;
    return s;
}

// Solid-angle density (per steradian, without selection) of a point sampled uniformly by area on a
// surface of total area `area`: (1/area) d^2 / cos(theta_light). 0 where rejected.
float area_density(const Seen& s, double area) {
    if (!s.ok || !(area > 0)) return 0.0f;
    double pdf = s.d2 / (area * s.cos_light);
    return pdf < kMaxPdf ? float(pdf) : 0.0f;
}

// How a sphere looks from the reference point: from outside, the cone of directions it subtends.
struct SphereView {
    bool outside = false;
    Vec3d axis;          // unit, ref -> centre
    double dist = 0;     // |centre - ref|
    double sin2_max = 0; // sin^2(theta_max) = r^2 / d^2
    double omc = 0;      // 1 - cos(theta_max)
    float cone_pdf = 0;  // 1 / (2 pi omc) per steradian; 0 if it would overflow
};

SphereView view_sphere(Vec3 ref, const Sphere& sph) {
    SphereView v;
    Vec3d d = sub(to_d(sph.center), to_d(ref));
    double d2 = dot_d(d, d);
    double r = std::abs(double(sph.radius));
    if (!(d2 > r * r) || !std::isfinite(d2)) return v;  // inside or on the surface: area sampling
    v.outside = true;
    v.dist = std::sqrt(d2);
    v.axis = scale(d, 1.0 / v.dist);
    v.sin2_max = std::min(1.0, r * r / d2);
    // 1 - cos = 1 - sqrt(1 - s^2) = s^2 / (1 + sqrt(1 - s^2)): no cancellation for any s, so no
    // Taylor branch is needed for tiny or distant spheres (the veach_mi lights: r = 0.0333 at ~15
    // units, s^2 = 5e-6, where 1 - sqrt(1 - s^2) in float would be off by several percent).
    v.omc = v.sin2_max / (1.0 + std::sqrt(1.0 - v.sin2_max));
    double pdf = v.omc > 0 ? 1.0 / (2.0 * kPiD * v.omc) : HUGE_VAL;
    v.cone_pdf = pdf < kMaxPdf ? float(pdf) : 0.0f;
    return v;
}

// Duff et al. 2017 orthonormal basis around a unit vector, in double.
void basis_d(Vec3d n, Vec3d* s, Vec3d* t) {
    double sign = std::copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z);
    double b = n.x * n.y * a;
    *s = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    *t = {b, sign + n.y * n.y * a, -n.y};
}

Vec3 sphere_normal(const Sphere& sph, Vec3 p) {
    Vec3d d = sub(to_d(p), to_d(sph.center));
    double len = std::sqrt(dot_d(d, d));
    Vec3 n = len > 0 ? to_f(scale(d, 1.0 / len)) : Vec3(0, 0, 1);
    return sph.flip_normals ? -n : n;
}

// Area of triangle i of a mesh (double, from the same cross product the normal uses).
Vec3d triangle_cross(const Mesh& m, uint32_t tri) {
    const uint32_t* idx = &m.indices[3 * size_t(tri)];
    Vec3d p0 = to_d(m.positions[idx[0]]), p1 = to_d(m.positions[idx[1]]), p2 = to_d(m.positions[idx[2]]);
    return cross_d(sub(p1, p0), sub(p2, p0));
}

double triangle_area(const Mesh& m, uint32_t tri) {
    Vec3d c = triangle_cross(m, tri);
    double a = 0.5 * std::sqrt(dot_d(c, c));
    return std::isfinite(a) ? a : 0.0;  // a NaN/Inf vertex makes the triangle unusable, not the light
}

double mesh_area(const Mesh& m) {
    double a = 0;
    for (uint32_t t = 0; t < m.triangle_count(); ++t) a += triangle_area(m, t);
    return a;
}

// Mesh triangles that subtend at least kSolidAngleSampling steradians from the reference point are
// sampled uniformly in solid angle (Arvo 1995), the rest uniformly by area. By area the density per
// steradian, d^2 / (A cos(theta_light)), changes across a triangle by a relative amount of the order of
// its angular size: nothing for a far triangle (where area sampling is also cheaper), but near a large
// light (the walls below a ceiling panel, a lamp's own housing) the 1/d^2 of the nearest points makes
// NEE's fireflies. Past kMaxSolidAngle (a point almost on the triangle's plane, facing it) Arvo's
// construction loses precision, and area sampling is used again. Both bounds are decided from the
// same TriangleView in sample_light and light_pdf, so the densities still agree bit for bit.
constexpr double kMinSolidAngle = kSolidAngleSampling;
constexpr double kMaxSolidAngle = 6.2;  // sr (a hemisphere is 2 pi = 6.28)

// Triangle `tri` of a mesh light as seen from ref: whether it is sampled in solid angle, and then the
// unit directions to its vertices and the solid angle they span.
struct TriangleView {
    bool spherical = false;
    Vec3d a, b, c;           // unit directions ref -> vertices 0, 1, 2
    double solid_angle = 0;  // sr
    double height = 0;       // n . (vertex 0 - ref): minus ref's distance to the triangle's plane (< 0)
};

// Whether triangle `tri` may subtend kMinSolidAngle or more from ref: a cheap bound that sends far
// triangles (the usual case) to area sampling without view_triangle's square roots and arctangent. Every
// point q of the triangle lies at least d = max(D - r, h) from ref (D: distance to the centroid, r: the
// centroid's largest distance to a vertex, h: ref's height above the triangle's plane) and sees ref at
// cos = h / |q - ref|, so the solid angle, the integral of cos / |q - ref|^2 over the area A, is at most
// A h / d^3. (Rounding at the bound may tip a triangle either way; sample_light and light_pdf decide
// alike, so the densities still agree.)
inline bool maybe_near(const Light& l, uint32_t tri, Vec3 ref) {
    const Light::Triangle& b = l.triangle_info[tri];
    const Vec3 dc = ref - b.centre;
    const float h = dot(b.normal, dc);
    if (!(h > 0)) return false;                 // behind the emitting side: area sampling rejects it
    if (h * h > b.area_over_min) return false;  // d >= h, so A h / d^3 <= A / h^2 < kMinSolidAngle
    const float d = std::max(std::sqrt(dot(dc, dc)) - b.radius, h);
    return h * b.area_over_min >= d * d * d;
}

// The exact view, for triangles that maybe_near lets through.
TriangleView view_triangle(const Mesh& m, uint32_t tri, Vec3 n, Vec3 ref) {
    TriangleView v;
    const uint32_t* idx = &m.indices[3 * size_t(tri)];
    const Vec3d r = to_d(ref);
    const Vec3d d0 = sub(to_d(m.positions[idx[0]]), r), d1 = sub(to_d(m.positions[idx[1]]), r),
                d2 = sub(to_d(m.positions[idx[2]]), r);
    // Emitters radiate on their normal's side: ref must be strictly in front of the plane (otherwise
    // the area branch rejects every point of the triangle, as before).
    v.height = dot_d(to_d(n), d0);
    if (!(v.height < 0)) return v;
    const double l0 = dot_d(d0, d0), l1 = dot_d(d1, d1), l2 = dot_d(d2, d2);
    if (!(l0 > 0 && l1 > 0 && l2 > 0) || !std::isfinite(l0 + l1 + l2)) return v;
    v.a = scale(d0, 1.0 / std::sqrt(l0));
    v.b = scale(d1, 1.0 / std::sqrt(l1));
    v.c = scale(d2, 1.0 / std::sqrt(l2));
    // Van Oosterom and Strackee 1983: tan(Omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a).
    const double triple = std::abs(dot_d(v.a, cross_d(v.b, v.c)));
    const double den = 1.0 + dot_d(v.a, v.b) + dot_d(v.b, v.c) + dot_d(v.c, v.a);
    // In float: past the far test the angle is rarely far below kMinSolidAngle, where float's relative
    // 1e-7 is plenty (and its arctangent is several times cheaper than double's).
    v.solid_angle = 2.0 * double(std::atan2(float(triple), float(den)));
    v.spherical = v.solid_angle >= kMinSolidAngle && v.solid_angle <= kMaxSolidAngle;
    return v;
}

// Arvo 1995, "Stratified sampling of spherical triangles": the direction *w uniform in the spherical
// triangle (a, b, c). u.x picks the sub-triangle (a, b, c') of area u.x Omega, whose vertex c' on the arc
// a-c follows from the sub-triangle's angle sum; u.y then picks a point on the arc b-c' so that the
// density is uniform. False only where rounding leaves no direction (a sliver at the bounds' edge).
bool sample_spherical_triangle(const TriangleView& v, Vec2 u, Vec3d* w) {
    // The angle alpha at vertex a: between the great circles a-b and a-c, i.e. their planes' normals.
    const Vec3d nab = cross_d(v.a, v.b), nac = cross_d(v.a, v.c);
    const double len2 = dot_d(nab, nab) * dot_d(nac, nac);
    if (!(len2 > 0)) return false;
    const double cos_alpha = std::clamp(dot_d(nab, nac) / std::sqrt(len2), -1.0, 1.0);
    const double sin_alpha = std::sqrt(std::max(0.0, 1.0 - cos_alpha * cos_alpha));
    if (!(sin_alpha > 0)) return false;
    // Sub-triangle area A' = u.x Omega; with phi = A' - alpha, the cosine of the arc a-c' is q. sin and
    // cos of phi by the difference formulas: one sincos, no arccosine.
    const float area_u = float(double(u.x) * v.solid_angle);
    const float sin_a = std::sin(area_u), cos_a = std::cos(area_u);
    const double s = sin_a * cos_alpha - cos_a * sin_alpha, t = cos_a * cos_alpha + sin_a * sin_alpha;
    const double k1 = t - cos_alpha;
    const double k2 = s + sin_alpha * dot_d(v.a, v.b);
    const double q_raw = ((k2 * t - k1 * s) * cos_alpha - k2) / ((k2 * s + k1 * t) * sin_alpha);
    if (!std::isfinite(q_raw)) return false;  // 0/0: a degenerate triangle, or u on an edge's line
    const double q = std::clamp(q_raw, -1.0, 1.0);
    const Vec3d c_perp = sub(v.c, scale(v.a, dot_d(v.c, v.a)));  // the arc a-c's tangent at a
    const double cp2 = dot_d(c_perp, c_perp);
    if (!(cp2 > 0)) return false;
    const Vec3d c1 = add(scale(v.a, q), scale(c_perp, std::sqrt(1.0 - q * q) / std::sqrt(cp2)));
    // Uniform on the arc b-c' in the sense that makes the whole density uniform: z = cos of the arc from b.
    const double z = std::clamp(1.0 - double(u.y) * (1.0 - dot_d(c1, v.b)), -1.0, 1.0);
    const Vec3d b_perp = sub(c1, scale(v.b, dot_d(c1, v.b)));
    const double bp2 = dot_d(b_perp, b_perp);
    if (!(bp2 > 0)) {  // c' = b to double precision: the arc has no length
        *w = v.b;
        return true;
    }
    *w = add(scale(v.b, z), scale(b_perp, std::sqrt(std::max(0.0, 1.0 - z * z)) / std::sqrt(bp2)));
    return std::isfinite(w->x + w->y + w->z);
}

// Density per steradian (without light selection) of a triangle sampled in solid angle: its share of
// the light's area (the triangle's selection probability) over its solid angle.
float spherical_density(const Light& l, uint32_t tri, const TriangleView& v) {
    return float(double(l.triangles.pmf(tri)) / v.solid_angle);
}

// The solid-angle branch of sample_mesh: a direction uniform in the triangle's spherical triangle, and
// the point where it meets the triangle's plane.
bool sample_mesh_solid_angle(const Light& l, uint32_t tri, Vec3 n, const TriangleView& view, Vec3 ref, Vec2 u,
                             LightSample* s) {
    Vec3d w;
    if (!sample_spherical_triangle(view, u, &w)) return false;
    const double cos_w = dot_d(to_d(n), w);
    const double dist = view.height / cos_w;  // both < 0: ref is in front of the plane, w points at it
    if (!(cos_w < 0) || !(dist > 0) || !std::isfinite(dist)) return false;
    s->p = to_f(add(to_d(ref), scale(w, dist)));
    s->n = n;
    s->wi = to_f(w);
    s->dist = float(dist);
    s->radiance = l.radiance;
    s->pdf = spherical_density(l, tri, view);
    s->prim = tri;
    return s->pdf > 0;
}

bool sample_mesh(const Scene& scene, const Light& l, Vec3 ref, float u_tri, Vec2 u, LightSample* s) {
    if (l.triangles.empty() || !(l.area > 0)) return false;
    const Mesh& m = scene.meshes[l.shape];
    uint32_t tri = l.triangles.sample(u_tri);
    const Vec3 n = l.triangle_info[tri].normal;
    if (n.x == 0 && n.y == 0 && n.z == 0) return false;  // unreachable: zero-area triangles have weight 0
    if (maybe_near(l, tri, ref)) {
        const TriangleView view = view_triangle(m, tri, n, ref);
        if (view.spherical) return sample_mesh_solid_angle(l, tri, n, view, ref, u, s);
    }
    const uint32_t* idx = &m.indices[3 * size_t(tri)];
    Vec3 p0 = m.positions[idx[0]], p1 = m.positions[idx[1]], p2 = m.positions[idx[2]];
    Vec2 b = sample_uniform_triangle(u);
    // Same interpolation as Scene::intersect, so a sampled point and a hit point agree.
    Vec3 p = p0 * (1.0f - b.x - b.y) + p1 * b.x + p2 * b.y;
    Seen seen = see_area_point(ref, p, n);
    // Triangles are chosen in proportion to area and sampled uniformly, so the area density is
    // 1/total area on every triangle.
    float pdf = area_density(seen, l.area);
    if (pdf <= 0) return false;
    s->p = p;
    s->n = n;
    s->wi = seen.wi;
    s->dist = seen.dist;
    s->radiance = l.radiance;
    s->pdf = pdf;
    s->prim = tri;
    return true;
}

// Conditional density (per steradian, without selection) of the mesh sampler at point p, normal n, of
// triangle tri.
float mesh_density(const Scene& scene, const Light& l, uint32_t tri, Vec3 ref, Vec3 p, Vec3 n) {
    if (l.triangles.empty() || tri >= l.triangle_info.size()) return 0.0f;
    if (maybe_near(l, tri, ref)) {
        const TriangleView view = view_triangle(scene.meshes[l.shape], tri, l.triangle_info[tri].normal, ref);
        if (view.spherical) return spherical_density(l, tri, view);
    }
    return area_density(see_area_point(ref, p, n), l.area);
}

// Conditional density (per steradian, without selection) of the sphere sampler at point p, normal n.
float sphere_density(const Sphere& sph, const Light& l, Vec3 ref, Vec3 p, Vec3 n) {
    SphereView v = view_sphere(ref, sph);
    Seen seen = see_area_point(ref, p, n);
    if (!seen.ok) return 0.0f;
    if (v.outside) return v.cone_pdf;
    return area_density(seen, l.area);
}

bool sample_sphere(const Scene& scene, const Light& l, Vec3 ref, Vec2 u, LightSample* s) {
    const Sphere& sph = scene.spheres[l.shape];
    SphereView v = view_sphere(ref, sph);
    double r = std::abs(double(sph.radius));
    Vec3 p;
    if (v.outside) {
        if (v.cone_pdf <= 0) return false;
        // Uniform direction in the subtended cone: the same mapping as sample_uniform_cone(u,
        // OneMinusCos), here in double because the point on the sphere is derived from it.
        double t = double(u.x) * v.omc;        // 1 - cos(theta)
        double sin2 = t * (2.0 - t);           // sin^2(theta)
        double cos_theta = 1.0 - t;
        // The point the direction hits, without intersecting a ray (pbrt-v4's method): by the law of
        // cosines in the triangle (ref, centre, hit), the hit lies at angle alpha from the centre's
        // direction back to ref, with cos(alpha) = sin^2(theta)/sin(theta_max)
        //   + cos(theta) sqrt(1 - sin^2(theta)/sin^2(theta_max)).
        // Unlike a ray-sphere test this never misses at the cone's rim, where the discriminant of the
        // quadratic cancels catastrophically.
        double sin_max = std::sqrt(v.sin2_max);
        double cos_alpha = sin2 / sin_max + cos_theta * std::sqrt(std::max(0.0, 1.0 - sin2 / v.sin2_max));
        cos_alpha = std::min(1.0, std::max(-1.0, cos_alpha));
        double sin_alpha = std::sqrt(std::max(0.0, 1.0 - cos_alpha * cos_alpha));
        double phi = 2.0 * kPiD * double(u.y);
        Vec3d e1, e2;
        basis_d(v.axis, &e1, &e2);
        // Seen from the centre, the hit has the same azimuth about the axis as the direction from ref.
        double ca = sin_alpha * std::cos(phi), sa = sin_alpha * std::sin(phi);
        Vec3d local = {ca * e1.x + sa * e2.x - cos_alpha * v.axis.x, ca * e1.y + sa * e2.y - cos_alpha * v.axis.y,
                       ca * e1.z + sa * e2.z - cos_alpha * v.axis.z};
        Vec3d c = to_d(sph.center);
        p = to_f({c.x + r * local.x, c.y + r * local.y, c.z + r * local.z});
    } else {
        // Inside (or on) the sphere every point may be visible: uniform by area.
        if (!(l.area > 0)) return false;
        Vec3 w = sample_uniform_sphere(u);
        p = sph.center + w * float(r);
    }
    Vec3 n = sphere_normal(sph, p);
    float pdf = sphere_density(sph, l, ref, p, n);
    if (pdf <= 0) return false;
    Seen seen = see_area_point(ref, p, n);
    s->p = p;
    s->n = n;
    s->wi = seen.wi;
    s->dist = seen.dist;
    s->radiance = l.radiance;
    s->pdf = pdf;
    return true;
}

// no surface normal; `radiance` already holds the intensity over the squared distance (W/(m^2 sr)).
void set_point_sample(Vec3 position, Vec3 wi, double dist, RGB radiance, LightSample* s) {
    s->p = position;
    s->n = Vec3(0);
    s->wi = wi;
    s->dist = float(dist);
    s->radiance = radiance;
    s->pdf = 1.0f;
    s->delta = true;
}

}  // namespace

double scene_radius(const Scene& scene) {
    Vec3 lo = scene.bounds_min, hi = scene.bounds_max;
    bool valid = is_finite(lo) && is_finite(hi) && lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z;
    if (!valid) {
        lo = Vec3(kInf);
        hi = Vec3(-kInf);
        for (const Mesh& m : scene.meshes)
            for (Vec3 p : m.positions) {
                lo = vmin(lo, p);
                hi = vmax(hi, p);
            }
        for (const Sphere& s : scene.spheres) {
            float r = std::abs(s.radius);
            lo = vmin(lo, s.center - Vec3(r));
            hi = vmax(hi, s.center + Vec3(r));
        }
        if (!(lo.x <= hi.x)) return 0.0;  // no geometry
    }
    Vec3d ext = sub(to_d(hi), to_d(lo));
    return 0.5 * std::sqrt(dot_d(ext, ext));
}

float spot_falloff(float cutoff, float beam_width, float cos_cutoff, float cos_theta) {
    if (!(cos_theta > cos_cutoff)) return 0.0f;
    const float theta = safe_acos(cos_theta);
    if (theta <= beam_width || !(cutoff > beam_width)) return 1.0f;
    return std::min(1.0f, std::max(0.0f, (cutoff - theta) / (cutoff - beam_width)));
}

RGB light_emitted(const Light& l, Vec3 n, Vec3 w) {
    switch (l.type) {
        case LightType::AreaMesh:
        case LightType::AreaSphere: return dot(n, w) > 0 ? l.radiance : RGB(0);
        case LightType::Constant: return l.radiance;
        case LightType::Envmap: return envmap_eval(*l.envmap, -w);
        case LightType::Point:
        case LightType::Spot:
        case LightType::Directional: return RGB(0);  // deltas: no ray hits them
    }
    return RGB(0);
}

RGB light_power(const Scene& scene, const Light& l) {
    // One-sided Lambertian emitters: the radiant exitance is pi L, so the power is pi A L.
    switch (l.type) {
        case LightType::AreaMesh: {
            double area = l.area > 0 ? double(l.area)
                                     : (l.shape < scene.meshes.size() ? mesh_area(scene.meshes[l.shape]) : 0.0);
            return l.radiance * float(kPiD * area);
        }
        case LightType::AreaSphere: {
            double r = l.shape < scene.spheres.size() ? double(scene.spheres[l.shape].radius) : 0.0;
            return l.radiance * float(kPiD * 4.0 * kPiD * r * r);
        }
        case LightType::Point: return l.radiance * float(4.0 * kPiD);  // isotropic intensity over 4 pi sr
        case LightType::Constant: {
            // The flux through the scene's bounding sphere of radius R: a disk of area pi R^2 facing
            // each direction, times 4 pi sr of incoming directions (as pbrt and Mitsuba estimate it).
            return l.radiance * float(bounding_disk_area(scene) * 4.0 * kPiD);
        }
        case LightType::Envmap: {
            // As for the constant environment, with the map's integral over the sphere for 4 pi L.
            return l.envmap ? l.envmap->integral * float(bounding_disk_area(scene)) : RGB(0);
        }
        case LightType::Directional: {
            // The flux through a disk of the bounding sphere's radius facing the light.
            return l.radiance * float(bounding_disk_area(scene));
        }
        case LightType::Spot: {
            // 2 pi times the integral of falloff(theta) sin(theta) dtheta: 1 - cos(beam) over the full
            // beam, and over the linear ramp (from integrating (c - t) sin t by parts)
            //   ((c - b) cos b + sin b - sin c) / (c - b).
            const double c = l.cutoff, b = std::min(double(l.beam_width), c);
            double solid = 1.0 - std::cos(b);
            if (c > b) solid += ((c - b) * std::cos(b) + std::sin(b) - std::sin(c)) / (c - b);
            return l.radiance * float(2.0 * kPiD * solid);
        }
    }
    return RGB(0);
}

void lights_prepare(Scene& scene) {
    scene.environment_light = -1;
    std::vector<float> weights(scene.lights.size(), 0.0f);
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        Light& l = scene.lights[i];
        const std::string who = "light " + std::to_string(i);
        switch (l.type) {
            case LightType::AreaMesh: {
                if (l.shape >= scene.meshes.size()) throw std::runtime_error(who + ": mesh index out of range");
                const Mesh& m = scene.meshes[l.shape];
                std::vector<float> areas(m.triangle_count());
                for (uint32_t t = 0; t < m.triangle_count(); ++t) areas[t] = float(triangle_area(m, t));
                l.triangles = Distribution1D(areas);
                // Per triangle (Light::Triangle): its normal, and what maybe_near's bound needs (centroid,
                // the centroid's largest distance to a vertex, area over the threshold).
                l.triangle_info.assign(m.triangle_count(), Light::Triangle{});
                for (uint32_t t = 0; t < m.triangle_count(); ++t) {
                    Light::Triangle& info = l.triangle_info[t];
                    const uint32_t* idx = &m.indices[3 * size_t(t)];
                    const Vec3d p[3] = {to_d(m.positions[idx[0]]), to_d(m.positions[idx[1]]), to_d(m.positions[idx[2]])};
                    const Vec3d centre = scale(add(add(p[0], p[1]), p[2]), 1.0 / 3.0);
                    double r2 = 0;
                    for (const Vec3d& q : p) r2 = std::max(r2, dot_d(sub(q, centre), sub(q, centre)));
                    info.centre = to_f(centre);
                    info.radius = float(std::sqrt(r2));
                    info.area_over_min = float(double(areas[t]) / kMinSolidAngle);
                    const Vec3d c = triangle_cross(m, t);
                    const double len = std::sqrt(dot_d(c, c));
                    if (!(len > 0)) continue;
                    const Vec3 n = to_f(scale(c, 1.0 / len));
                    info.normal = m.flip_normals ? -n : n;
                }
                l.area = float(l.triangles.total());
                break;
            }
            case LightType::AreaSphere: {
                if (l.shape >= scene.spheres.size()) throw std::runtime_error(who + ": sphere index out of range");
                double r = scene.spheres[l.shape].radius;
                l.area = float(4.0 * kPiD * r * r);
                break;
            }
            case LightType::Point: break;
            case LightType::Spot:
            case LightType::Directional:
                if (!(std::abs(length(l.direction) - 1.0f) < 1e-3f))
                    throw std::runtime_error(who + ": direction is not a unit vector");
                break;
            case LightType::Envmap:
                if (!l.envmap) throw std::runtime_error(who + ": environment map missing");
                [[fallthrough]];
            case LightType::Constant:
                if (scene.environment_light >= 0)
                    throw std::runtime_error(who + ": only one environment emitter is allowed per scene");
                scene.environment_light = int(i);
                break;
        }
        float w = luminance(light_power(scene, l)) * l.sampling_weight;
        if (!std::isfinite(w)) throw std::runtime_error(who + ": power is not finite");
        weights[i] = std::max(w, 0.0f);  // zero (or negative) power: never chosen
    }
    scene.light_selection = Distribution1D(weights);
}

float light_selection_pmf(const Scene& scene, uint32_t light) { return scene.light_selection.pmf(light); }

bool sample_light(const Scene& scene, Vec3 ref, float u_sel, Vec2 u, LightSample* s) {
    *s = LightSample{};
    if (scene.light_selection.empty()) return false;
    float u_rest;  // u_sel rescaled inside the chosen light's bin: reused to pick a triangle
    uint32_t i = scene.light_selection.sample(u_sel, &u_rest);
    float pmf = scene.light_selection.pmf(i);
    if (!(pmf > 0)) return false;
    const Light& l = scene.lights[i];
    bool ok = false;
    switch (l.type) {
        case LightType::AreaMesh: ok = sample_mesh(scene, l, ref, u_rest, u, s); break;
        case LightType::AreaSphere: ok = sample_sphere(scene, l, ref, u, s); break;
        case LightType::Point: {
            Vec3d d = sub(to_d(l.position), to_d(ref));
            double d2 = dot_d(d, d);
            if (!(d2 > 0) || !std::isfinite(d2)) break;
            double dist = std::sqrt(d2);
            RGB radiance = l.radiance * float(1.0 / d2);
            if (!is_finite(radiance)) break;  // reference point (nearly) on the light
            set_point_sample(l.position, to_f(scale(d, 1.0 / dist)), dist, radiance, s);
            ok = true;
            break;
        }
        case LightType::Spot: {
            Vec3d d = sub(to_d(l.position), to_d(ref));
            double d2 = dot_d(d, d);
            if (!(d2 > 0) || !std::isfinite(d2)) break;
            double dist = std::sqrt(d2);
            Vec3 wi = to_f(scale(d, 1.0 / dist));
            float fall = spot_falloff(l.cutoff, l.beam_width, l.cos_cutoff, dot(-wi, l.direction));
            if (!(fall > 0)) break;
            RGB radiance = l.radiance * float(fall / d2);
            if (!is_finite(radiance)) break;
            set_point_sample(l.position, wi, dist, radiance, s);
            ok = true;
            break;
        }
        case LightType::Directional: {
            // Irradiance E arrives along -direction: a delta in direction whose "radiance" is E.
            s->wi = -l.direction;
            s->p = Vec3(0);
            s->n = Vec3(0);
            s->dist = kInf;
            s->radiance = l.radiance;
            s->pdf = 1.0f;
            s->delta = true;
            ok = true;
            break;
        }
        case LightType::Envmap: {
            float pdf;
            Vec3 wi;
            if (!envmap_sample(*l.envmap, u, &wi, &pdf)) break;
            s->wi = wi;
            s->p = Vec3(0);
            s->n = Vec3(0);
            s->dist = kInf;
            s->radiance = envmap_eval(*l.envmap, wi);
            s->pdf = pdf;
            ok = !is_black(s->radiance);
            break;
        }
        case LightType::Constant: {
            s->wi = sample_uniform_sphere(u);
            s->p = Vec3(0);
            s->n = Vec3(0);
            s->dist = kInf;
            s->radiance = l.radiance;
            s->pdf = kInv4Pi;
            ok = true;
            break;
        }
    }
    if (!ok) {
        *s = LightSample{};
        return false;
    }
    s->pdf *= pmf;  // same product, same order as light_pdf
    if (IRIS_MUTANT(light_sample_pdf_scale)) s->pdf *= 1.1f;
    s->light = i;
    if (!(s->pdf > 0)) {  // underflow: light_pdf reports 0 for this point too
        *s = LightSample{};
        return false;
    }
    return true;
}

float light_pdf(const Scene& scene, uint32_t light, uint32_t prim, Vec3 ref, Vec3 p, Vec3 n, Vec3 wi) {
    if (light >= scene.lights.size()) return 0.0f;
    float pmf = light_selection_pmf(scene, light);
    if (!(pmf > 0)) return 0.0f;
    const Light& l = scene.lights[light];
    float pdf = 0;
    switch (l.type) {
        case LightType::AreaMesh: pdf = mesh_density(scene, l, prim, ref, p, n); break;
        case LightType::AreaSphere: pdf = sphere_density(scene.spheres[l.shape], l, ref, p, n); break;
        case LightType::Point:
        case LightType::Spot:
        case LightType::Directional: pdf = 1.0f; break;  // the delta's mass, as LightSample::pdf reports it
        case LightType::Constant: pdf = kInv4Pi; break;
        case LightType::Envmap: pdf = envmap_pdf(*l.envmap, wi); break;
    }
    if (IRIS_MUTANT(light_pdf_scale) && l.type == LightType::AreaMesh) pdf *= 1.1f;
    return pdf * pmf;
}

}  // namespace iris
