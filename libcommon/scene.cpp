#include "libcommon/scene.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#include "libcommon/accel.h"

namespace iris {

Scene::Scene() = default;
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

void Scene::finalize() {
    bounds_min = Vec3(kInf);
    bounds_max = Vec3(-kInf);
    for (const Mesh& m : meshes)
        for (Vec3 p : m.positions) {
            bounds_min = vmin(bounds_min, p);
            bounds_max = vmax(bounds_max, p);
        }
    for (const Sphere& s : spheres) {
        bounds_min = vmin(bounds_min, s.center - Vec3(s.radius));
        bounds_max = vmax(bounds_max, s.center + Vec3(s.radius));
    }
    if (meshes.empty() && spheres.empty()) bounds_min = bounds_max = Vec3(0);
    for (Bsdf& b : bsdfs) {
        bsdf_prepare(b);
        for (int16_t i : {b.tex_diffuse, b.tex_specular, b.tex_transmittance, b.tex_alpha_u, b.tex_alpha_v, b.tex_opacity, b.tex_blend})
            if (i >= 0 && size_t(i) >= textures.size())
                throw std::runtime_error("a BSDF refers to texture " + std::to_string(i) + " of " +
                                         std::to_string(textures.size()));
    }
    // A Mixture's parts are entries of this array added before it (the loader adds a part as it reads
    // it), so linking in index order finds every part already linked.
    for (size_t k = 0; k < bsdfs.size(); ++k) {
        Bsdf& b = bsdfs[k];
        if (b.type != BsdfType::Mixture) continue;
        const Bsdf* parts[kMaxBsdfParts];
        for (int i = 0; i < b.part_count; ++i) {
            if (b.part_index[i] >= k) throw std::runtime_error("a mixture BSDF's part is not an earlier BSDF");
            parts[i] = &bsdfs[b.part_index[i]];
        }
        bsdf_link_parts(b, parts);
    }
    lights_prepare(*this);
    accel = std::make_shared<Accel>(*this);
}

namespace {

// Mitsuba 0.5's `bumpmap`: the displacement h(u, v) (the texture's luminance) moves the surface along its
// shading normal n. The tangents become dpdu + n (dh/du - n.dpdu) and likewise for v (Mitsuba's form: it
// also drops the tangents' own normal components, and ignores how n itself turns), and their cross product,
// turned to ng's side, is the new shading normal. n where the tangents are degenerate.
Vec3 bumped_normal(const Texture& bump, Vec2 uv, Vec3 n, Vec3 ng, Vec3 dpdu, Vec3 dpdv) {
    RGB gu, gv;
    texture_gradient(bump, uv, &gu, &gv);
    const float hu = luminance(gu), hv = luminance(gv);
    const Vec3 su = dpdu + n * (hu - dot(n, dpdu)), sv = dpdv + n * (hv - dot(n, dpdv));
    const Vec3 b = cross(su, sv);
    const float l = length(b);
    if (!(l > 0) || !std::isfinite(l)) return n;
    return dot(b, ng) < 0 ? b * (-1.0f / l) : b * (1.0f / l);
}

}  // namespace

bool Scene::intersect(const Ray& ray, SurfaceHit* h) const {
    float t, u, v;
    uint32_t geom, prim;
    if (!accel->intersect(ray, &t, &geom, &prim, &u, &v)) return false;
    h->t = t;
    h->geom = geom;
    h->prim = prim;
    const GeomRef& ref = geoms[geom];
    if (ref.kind == GeomRef::MeshKind) {
        const Mesh& m = meshes[ref.index];
        const uint32_t* idx = &m.indices[3 * size_t(prim)];
        Vec3 p0 = m.positions[idx[0]], p1 = m.positions[idx[1]], p2 = m.positions[idx[2]];
        float b0 = 1.0f - u - v;
        // The position from barycentrics is accurate to the vertices' own rounding, unlike o + t d.
        h->p = p0 * b0 + p1 * u + p2 * v;
        h->magnitude = std::max(max_abs_component(p0), std::max(max_abs_component(p1), max_abs_component(p2)));
        Vec3 ng = cross(p1 - p0, p2 - p0);
        float len = length(ng);
        ng = len > 0 ? ng / len : Vec3(0, 0, 1);
        if (m.flip_normals) ng = -ng;
        h->ng = ng;
        Vec3 ns = ng;
        if (!m.normals.empty()) {
            Vec3 n = m.normals[idx[0]] * b0 + m.normals[idx[1]] * u + m.normals[idx[2]] * v;
            float l = length(n);
            if (l > 1e-12f && std::isfinite(l)) ns = (m.flip_normals ? -n : n) / l;
        }
        h->ns = ns;
        h->bsdf = m.bsdf;
        h->light = m.light;
        // Only where a texture will read it: meshes from PLY files often carry uvs their BSDF ignores.
        // A mesh without uvs gets the barycentrics of vertices 1 and 2, as in Mitsuba's TriMesh.
        h->uv = Vec2{};
        const Bsdf& b = bsdfs[m.bsdf];
        if (b.textured) {
            // dp/du, dp/dv of the triangle's uv parametrisation, for a bump map.
            Vec3 dpdu = p1 - p0, dpdv = p2 - p0;  // (without uvs: uv = (u, v), the barycentrics)
            h->uv = mesh_uv(m, prim, u, v);
            if (!m.uvs.empty()) {
                const Vec2 t0 = m.uvs[idx[0]], t1 = m.uvs[idx[1]], t2 = m.uvs[idx[2]];
                if (b.tex_bump >= 0) {
                    const float du1 = t1.x - t0.x, dv1 = t1.y - t0.y, du2 = t2.x - t0.x, dv2 = t2.y - t0.y;
                    const float det = du1 * dv2 - dv1 * du2;
                    const Vec3 e1 = dpdu, e2 = dpdv;
                    dpdu = (e1 * dv2 - e2 * dv1) * (1.0f / det);
                    dpdv = (e2 * du1 - e1 * du2) * (1.0f / det);  // (det = 0: not finite, no bump)
                }
            }
            if (b.tex_bump >= 0) h->ns = bumped_normal(textures[size_t(b.tex_bump)], h->uv, ns, ng, dpdu, dpdv);
        }
    } else {
        const Sphere& s = spheres[ref.index];
        Vec3 d = (ray.o + ray.d * t) - s.center;
        float l = length(d);
        Vec3 n = l > 0 ? d / l : Vec3(0, 0, 1);
        // Re-project onto the sphere: the point is then exact up to the rounding of c + r n.
        h->p = s.center + n * s.radius;
        h->magnitude = max_abs_component(s.center) + s.radius;
        h->ng = s.flip_normals ? -n : n;
        h->ns = h->ng;
        h->bsdf = s.bsdf;
        h->light = s.light;
        h->uv = Vec2{};
        if (bsdfs[s.bsdf].textured) {
            h->uv = sphere_uv(s, n);
            if (const Bsdf& b = bsdfs[s.bsdf]; b.tex_bump >= 0) {
                const float lx = dot(n, s.axis_x), ly = dot(n, s.axis_y), lz = dot(n, s.axis_z);
                float phi = std::atan2(ly, lx);  // (as sphere_uv, before its scaling)
                if (phi < 0) phi += 2.0f * kPi;
                const float theta = std::acos(std::clamp(lz, -1.0f, 1.0f));
                // Mitsuba's sphere: dp/du = 2 pi r (-y, x, 0), dp/dv = pi r (z cos phi, z sin phi, -sin theta)
                // in the object frame (x, y, z the unit position); degenerate at the poles (no bump there).
                const float sin_t = std::sin(theta), cos_p = std::cos(phi), sin_p = std::sin(phi);
                const Vec3 dpdu = (s.axis_x * -ly + s.axis_y * lx) * (2.0f * kPi * s.radius);
                const Vec3 dpdv = (s.axis_x * (lz * cos_p) + s.axis_y * (lz * sin_p) + s.axis_z * -sin_t) * (kPi * s.radius);
                h->ns = bumped_normal(textures[size_t(b.tex_bump)], h->uv, h->ns, h->ng, dpdu, dpdv);
            }
        }
    }
    h->frame = Frame(h->ns);
    return true;
}

Vec2 mesh_uv(const Mesh& m, uint32_t prim, float u, float v) {
    if (m.uvs.empty()) return Vec2{u, v};
    const uint32_t* idx = &m.indices[3 * size_t(prim)];
    const Vec2 t0 = m.uvs[idx[0]], t1 = m.uvs[idx[1]], t2 = m.uvs[idx[2]];
    const float b0 = 1.0f - u - v;
    return Vec2{t0.x * b0 + t1.x * u + t2.x * v, t0.y * b0 + t1.y * u + t2.y * v};
}

Vec2 sphere_uv(const Sphere& s, Vec3 n) {
    // Mitsuba's sphere: uv = (phi / 2 pi, theta / pi) of the outward direction in the object frame,
    // phi in [0, 2 pi) from the x axis towards y, theta from +z.
    const float lx = dot(n, s.axis_x), ly = dot(n, s.axis_y), lz = dot(n, s.axis_z);
    float phi = std::atan2(ly, lx);
    if (phi < 0) phi += 2.0f * kPi;
    const float theta = std::acos(std::clamp(lz, -1.0f, 1.0f));
    return Vec2{phi * (0.5f * kInvPi), theta * kInvPi};
}

namespace {
// b's textured parameters evaluated at uv into *out (a copy of b).
void resolve_params(const Scene& scene, const Bsdf& b, Vec2 uv, Bsdf* out) {
    *out = b;
    Bsdf& r = *out;
    const std::vector<Texture>& t = scene.textures;
    if (b.tex_diffuse >= 0) r.diffuse = texture_eval(t[size_t(b.tex_diffuse)], uv);
    if (b.tex_specular >= 0) r.specular = texture_eval(t[size_t(b.tex_specular)], uv);
    if (b.tex_transmittance >= 0) r.transmittance = texture_eval(t[size_t(b.tex_transmittance)], uv);
    // Roughness: the texture's mean over R, G, B (Mitsuba's average()), floored at the 1e-4 the loader
    // applies to constant roughness (smaller is numerically a mirror).
    auto alpha = [&](int16_t i) {
        const RGB a = texture_eval(t[size_t(i)], uv);
        return std::max((a.r + a.g + a.b) * (1.0f / 3.0f), 1e-4f);
    };
    if (b.tex_alpha_u >= 0) r.alpha_u = alpha(b.tex_alpha_u);
    if (b.tex_alpha_v >= 0) r.alpha_v = alpha(b.tex_alpha_v);
    // blendbsdf's weight: the texture's mean, clamped to [0, 1] as Mitsuba does at every lookup.
    if (b.tex_blend >= 0) {
        const RGB t_w = texture_eval(t[size_t(b.tex_blend)], uv);
        const float w = std::clamp((t_w.r + t_w.g + t_w.b) * (1.0f / 3.0f), 0.0f, 1.0f);
        r.part_weight[0] = 1 - w;
        r.part_weight[1] = w;
    }
    bsdf_refresh_weights(r);
}
}  // namespace

const Bsdf& resolve_textured_bsdf(const Scene& scene, const Bsdf& b, Vec2 uv, BsdfScratch* scratch) {
    Bsdf& r = scratch->bsdf;
    resolve_params(scene, b, uv, &r);
    if (b.type == BsdfType::Mixture)
        for (int i = 0; i < b.part_count; ++i)
            if (b.part[i]->textured_params) {
                resolve_params(scene, *b.part[i], uv, &scratch->parts[i]);
                r.part[i] = &scratch->parts[i];
            }
    return r;
}

bool Scene::occluded(const Ray& ray) const { return accel->occluded(ray); }

bool Scene::occluded(Vec3 from, Vec3 to) const {
    Ray r;
    r.o = from;
    r.d = to - from;
    r.tmin = 0;
    // Both ends are offset off their surfaces already; stop just short of the far end.
    r.tmax = 1.0f - 1e-4f;
    return accel->occluded(r);
}

Vec3 offset_ray_origin(Vec3 p, Vec3 ng, Vec3 w, float magnitude) {
    // The computed hit point (barycentric interpolation, or centre + radius * normal) and the next ray's
    // intersection test (Embree) both err by a few ULPs of the coordinates involved, so the origin moves
    // along the normal by kUlps ULPs of their magnitude m. Relative everywhere: the former scheme
    // (Waechter & Binder 2019: 256 integer ULPs per coordinate, and an absolute 1/65536 for coordinates
    // below 1/32) moved a point by 1.5 % of a millimetre-sized scene at the origin, and by a quarter of
    // a 2-unit box placed 1e4 away -- behind its own walls: light leaked in (+10 % brightness, measured
    // by tests/stress/test_scale_invariance.cpp). The stress test of rays leaving triangles (slivers
    // included) and spheres from both sides finds self-intersections at 4 ULPs and none at 8; 16 keeps
    // a factor of two. m includes the primitive's own magnitude: a point near the origin on a large
    // triangle carries the rounding of that triangle's vertices, not of its own small coordinates.
    constexpr float kUlps = 16.0f;
    const Vec3 n = dot(w, ng) < 0 ? -ng : ng;
    // 1e-30: a floor for a point at the exact origin (then its coordinates are exact, but not zero ULPs).
    const float m = std::max(std::max(max_abs_component(p), magnitude), 1e-30f);
    return p + n * (kUlps * 0x1p-23f * m);
}

bool has_specular_surfaces(const Scene& scene) {
    for (const Mesh& m : scene.meshes)
        if (bsdf_has_delta_lobe(scene.bsdfs[m.bsdf])) return true;
    for (const Sphere& s : scene.spheres)
        if (bsdf_has_delta_lobe(scene.bsdfs[s.bsdf])) return true;
    return false;
}

}  // namespace iris
