#include "libcommon/emission.h"

#include <algorithm>
#include <cmath>

#include "libcommon/sampling.h"
#include "libcommon/scene.h"

namespace iris {

namespace {

// An origin for a photon travelling along d from outside the scene: uniform on a disk of the bounding
// sphere's radius R, perpendicular to d, one radius before the centre. Every line along d that meets
// the scene crosses this disk, whose area is pi R^2 (bounding_disk_area, lights.h: the factor in
// light_power of the environment and directional lights).
Vec3 disk_origin(const Scene& scene, Vec3 d, Vec2 u) {
    Vec3 c = (scene.bounds_min + scene.bounds_max) * 0.5f;
    float r = float(scene_radius(scene));
    if (!(r > 0)) r = 1;
    Frame f(d);
    Vec2 disk = sample_concentric_disk(u);
    return c + (f.s * disk.x + f.t * disk.y) * r - d * r;
}

}  // namespace

bool sample_emission(const Scene& scene, float u_sel, Vec2 u_pos, Vec2 u_dir, EmissionSample* s) {
    if (scene.light_selection.empty()) return false;
    uint32_t li = scene.light_selection.sample(u_sel);
    float p_sel = scene.light_selection.pmf(li);
    if (!(p_sel > 0)) return false;
    const Light& l = scene.lights[li];
    s->light = li;
    // Area emitters are Lambertian, so directions are cosine-distributed about the normal and the flux
    // per photon is the light's total power over the selection probability; the spot light and the
    // envmap weight their samples by emitted / sampled density instead.
    s->flux = light_power(scene, l) / p_sel;
    switch (l.type) {
        case LightType::AreaMesh: {
            const Mesh& m = scene.meshes[l.shape];
            float u_tri;
            uint32_t tri = l.triangles.sample(u_pos.x, &u_tri);
            const uint32_t* idx = &m.indices[3 * size_t(tri)];
            Vec3 p0 = m.positions[idx[0]], p1 = m.positions[idx[1]], p2 = m.positions[idx[2]];
            Vec2 b = sample_uniform_triangle({u_tri, u_pos.y});
            s->p = p0 * (1 - b.x - b.y) + p1 * b.x + p2 * b.y;
            Vec3 n = cross(p1 - p0, p2 - p0);
            float len = length(n);
            if (!(len > 0)) return false;
            s->n = (m.flip_normals ? -n : n) / len;
            s->d = Frame(s->n).to_world(sample_cosine_hemisphere(u_dir));
            return true;
        }
        case LightType::AreaSphere: {
            const Sphere& sp = scene.spheres[l.shape];
            Vec3 n = sample_uniform_sphere(u_pos);
            s->p = sp.center + n * sp.radius;
            s->n = sp.flip_normals ? -n : n;
            s->d = Frame(s->n).to_world(sample_cosine_hemisphere(u_dir));
            return true;
        }
        case LightType::Point:
            s->p = l.position;
            s->n = Vec3(0);
            s->d = sample_uniform_sphere(u_dir);
            return true;
        case LightType::Spot: {
            // Uniform in the cutoff cone; flux I falloff / (p_cone p_select), p_cone = 1/(2 pi (1 - cos c)).
            const float omc = 1.0f - l.cos_cutoff;
            if (!(omc > 0)) return false;
            Vec3 local = sample_uniform_cone(u_dir, OneMinusCos{omc});
            s->d = Frame(l.direction).to_world(local);
            s->p = l.position;
            s->n = Vec3(0);
            const float fall = spot_falloff(l.cutoff, l.beam_width, l.cos_cutoff, local.z);
            s->flux = l.radiance * (fall * 2.0f * kPi * omc / p_sel);
            return fall > 0;
        }
        case LightType::Directional:
            // Every photon travels along the light's direction; flux E pi R^2 / p_select (light_power).
            s->d = l.direction;
            s->p = disk_origin(scene, s->d, u_pos);
            s->n = Vec3(0);
            return true;
        case LightType::Constant:
            // A direction of travel d, and an origin on a disk of the bounding sphere's radius R that
            // faces d from outside the scene: uniform over the disk, the flux is L * pi R^2 * 4 pi.
            s->d = -sample_uniform_sphere(u_dir);
            s->p = disk_origin(scene, s->d, u_pos);
            s->n = Vec3(0);
            return true;
        case LightType::Envmap: {
            // The direction the light arrives from, w, by the map's distribution; the photon travels
            // along -w with flux L(w) pi R^2 / (p(w) p_select).
            Vec3 w;
            float pdf;
            if (!envmap_sample(*l.envmap, u_dir, &w, &pdf)) return false;
            s->d = -w;
            s->p = disk_origin(scene, s->d, u_pos);
            s->n = Vec3(0);
            s->flux = envmap_eval(*l.envmap, w) * (float(bounding_disk_area(scene)) / (pdf * p_sel));
            return is_finite(s->flux) && !is_black(s->flux);
        }
    }
    return false;
}

bool scatter_light_path(const SurfaceHit& hit, const Bsdf& bsdf, Vec3 w_back, int depth, int rr_depth, Rng& rng,
                        RGB* beta, Vec3* wo_world, bool* delta) {
    const Vec3 wi = hit.frame.to_local(w_back);
    BsdfSample bs;
    const float uc = rng.next_float();
    const Vec2 u{rng.next_float(), rng.next_float()};
    if (!bsdf_sample(bsdf, wi, u, uc, &bs, TransportMode::Importance)) return false;
    const Vec3 wo = hit.frame.to_world(bs.wo);
    if (dot(wo, hit.ng) * bs.wo.z <= 0 || dot(w_back, hit.ng) * wi.z <= 0) return false;
    // Importance transport picks up |wi.ns||wo.ng| / (|wi.ng||wo.ns|), so that power is not created at
    // smooth-shaded edges.
    const float corr = std::abs(wi.z * dot(wo, hit.ng)) / std::abs(dot(w_back, hit.ng) * bs.wo.z);
    RGB next = *beta * bs.weight * (std::isfinite(corr) ? corr : 0.0f);
    if (depth >= rr_depth) {
        const float q = std::min(1.0f, max_component(next) / std::max(max_component(*beta), 1e-30f));
        if (!(rng.next_float() < q)) return false;
        next /= q;
    }
    *beta = next;
    *wo_world = wo;
    *delta = bs.delta;
    return true;
}

}  // namespace iris
