#include "libcommon/scene.h"

#include <bit>
#include <cstring>

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
    for (Bsdf& b : bsdfs) bsdf_prepare(b);
    lights_prepare(*this);
    accel = std::make_shared<Accel>(*this);
}

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
    } else {
        const Sphere& s = spheres[ref.index];
        Vec3 d = (ray.o + ray.d * t) - s.center;
        float l = length(d);
        Vec3 n = l > 0 ? d / l : Vec3(0, 0, 1);
        // Re-project onto the sphere: the point is then exact up to the rounding of c + r n.
        h->p = s.center + n * s.radius;
        h->ng = s.flip_normals ? -n : n;
        h->ns = h->ng;
        h->bsdf = s.bsdf;
        h->light = s.light;
    }
    h->frame = Frame(h->ns);
    return true;
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

Vec3 offset_ray_origin(Vec3 p, Vec3 ng, Vec3 w) {
    // Waechter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection" (Ray Tracing Gems,
    // 2019): move by a fixed number of ULPs of each coordinate, so the offset scales with |p| and the
    // method works at any scene scale; near the origin, where ULPs vanish, use a small absolute offset.
    constexpr float kOrigin = 1.0f / 32.0f;
    constexpr float kFloatScale = 1.0f / 65536.0f;
    constexpr float kIntScale = 256.0f;
    Vec3 n = dot(w, ng) < 0 ? -ng : ng;
    Vec3 r;
    for (int i = 0; i < 3; ++i) {
        int32_t of = int32_t(kIntScale * n[i]);
        int32_t bits = std::bit_cast<int32_t>(p[i]);
        float pi = std::bit_cast<float>(bits + (p[i] < 0 ? -of : of));
        r[i] = std::abs(p[i]) < kOrigin ? p[i] + kFloatScale * n[i] : pi;
    }
    return r;
}

}  // namespace iris
