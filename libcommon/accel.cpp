#include "libcommon/accel.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#include "libcommon/mutation.h"
#include "libcommon/rng.h"

namespace iris {

namespace {

void embree_error(void* user, RTCError code, const char* str) {
    // Embree calls this from inside API calls; construction checks rtcGetDeviceError afterwards.
    auto* last = static_cast<std::string*>(user);
    *last = str ? str : "unknown Embree error";
    (void)code;
}

thread_local std::string g_last_error;

void check(RTCDevice device, const char* what) {
    RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE)
        throw std::runtime_error(std::string("Embree: ") + what + ": " +
                                 (g_last_error.empty() ? "error " + std::to_string(int(e)) : g_last_error));
}

// Embree's filter for masked shapes (Embree calls it for each candidate hit on such a shape, in any ray
// query, closest-hit or occlusion): the hit stays with probability opacity, else it is rejected and the
// traversal goes on behind it, as if the surface were not there.
void mask_filter(const RTCFilterFunctionNArguments* args) {
    const auto* m = static_cast<const MaskedShape*>(args->geometryUserPtr);
    const unsigned n = args->N;
    for (unsigned i = 0; i < n; ++i) {
        if (args->valid[i] != -1) continue;
        RTCRayN* r = args->ray;
        RTCHitN* h = args->hit;
        const Vec3 o(RTCRayN_org_x(r, n, i), RTCRayN_org_y(r, n, i), RTCRayN_org_z(r, n, i));
        const Vec3 d(RTCRayN_dir_x(r, n, i), RTCRayN_dir_y(r, n, i), RTCRayN_dir_z(r, n, i));
        const Vec3 ng(RTCHitN_Ng_x(h, n, i), RTCHitN_Ng_y(h, n, i), RTCHitN_Ng_z(h, n, i));
        const uint32_t prim = RTCHitN_primID(h, n, i), geom = RTCHitN_geomID(h, n, i);
        // During the filter the ray's tfar is the candidate hit's distance.
        const float t = RTCRayN_tfar(r, n, i);
        const float alpha = mask_opacity(*m, prim, RTCHitN_u(h, n, i), RTCHitN_v(h, n, i), o + d * t);
        if (alpha >= 1.0f) continue;
        const bool stop = mask_uniform(o, d, geom, prim, dot(ng, d) > 0) < alpha;
        if (IRIS_MUTANT(mask_opacity_inverted) ? stop : !stop) args->valid[i] = 0;
    }
}

// Installs the mask filter on geometry g where the shape's BSDF is masked.
void maybe_mask(RTCGeometry g, const Scene& scene, uint32_t bsdf, const Mesh* mesh, const Sphere* sphere,
                std::vector<MaskedShape>* masked) {
    const Bsdf& b = scene.bsdfs[bsdf];
    if (!bsdf_is_masked(b)) return;
    MaskedShape m;
    m.opacity = b.opacity;
    m.texture = b.tex_opacity >= 0 ? &scene.textures[size_t(b.tex_opacity)] : nullptr;
    m.mesh = mesh;
    m.sphere = sphere;
    masked->push_back(m);  // reserved: the address stays
    rtcSetGeometryUserData(g, &masked->back());
    rtcSetGeometryIntersectFilterFunction(g, mask_filter);
    if (!IRIS_MUTANT(mask_shadow_rays_opaque)) rtcSetGeometryOccludedFilterFunction(g, mask_filter);
}

}  // namespace

float mask_opacity(const MaskedShape& m, uint32_t prim, float u, float v, Vec3 p) {
    if (!m.texture) return m.opacity;
    Vec2 uv;
    if (m.mesh) {
        uv = mesh_uv(*m.mesh, prim, u, v);
    } else {
        const Vec3 d = p - m.sphere->center;
        const float l = length(d);
        uv = sphere_uv(*m.sphere, l > 0 ? d / l : Vec3(0, 0, 1));
    }
    // Grey by construction (the loader refuses a coloured opacity), so luminance is any channel; clamped,
    // as a bilinear lookup of [0, 1] texels stays in [0, 1] up to rounding.
    return std::clamp(m.opacity * luminance(texture_eval(*m.texture, uv)), 0.0f, 1.0f);
}

float mask_uniform(Vec3 o, Vec3 d, uint32_t geom, uint32_t prim, bool back) {
    // Each 64-bit word of the key is folded in by a bijective mixer (rng.h's SplitMix64 finaliser):
    // flipping any input bit changes each output bit with probability ~1/2.
    auto bits = [](float f) {
        uint32_t b;
        std::memcpy(&b, &f, sizeof b);
        return uint64_t(b);
    };
    uint64_t h = 0;
    h = mix64(h ^ (bits(o.x) | bits(o.y) << 32));
    h = mix64(h ^ (bits(o.z) | bits(d.x) << 32));
    h = mix64(h ^ (bits(d.y) | bits(d.z) << 32));
    h = mix64(h ^ (uint64_t(geom) | uint64_t(prim) << 32));
    h = mix64(h ^ (back ? 1u : 2u));
    return float(h >> 40) * 0x1p-24f;  // 24 bits: every value exact, < 1
}

Accel::Accel(Scene& scene) {
    // Threads for the BVH build come from TBB's arena; "verbose=0" keeps Embree quiet.
    device_ = rtcNewDevice("verbose=0");
    if (!device_) throw std::runtime_error("Embree: cannot create a device");
    rtcSetDeviceErrorFunction(device_, embree_error, &g_last_error);
    scene_ = rtcNewScene(device_);
    // ROBUST: watertight triangle tests, so rays do not slip through shared edges (caustic paths
    // through closed glass meshes must not leak). HIGH quality: the scene is static and traced often.
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    scene.geoms.clear();
    masked_.reserve(scene.meshes.size() + scene.spheres.size());
    for (uint32_t i = 0; i < scene.meshes.size(); ++i) {
        Mesh& m = scene.meshes[i];
        RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        // Shared buffers: Embree reads the mesh's own arrays (Vec3 is 3 packed floats; Embree may read
        // 4 bytes past the last vertex, so the loader reserves one extra element).
        m.positions.reserve(m.positions.size() + 1);
        rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0,
                                   sizeof(Vec3), m.positions.size());
        rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.indices.data(), 0,
                                   3 * sizeof(uint32_t), m.triangle_count());
        maybe_mask(g, scene, m.bsdf, &m, nullptr, &masked_);
        rtcCommitGeometry(g);
        uint32_t id = rtcAttachGeometry(scene_, g);
        rtcReleaseGeometry(g);
        if (id != scene.geoms.size()) throw std::runtime_error("Embree: unexpected geometry ID");
        scene.geoms.push_back({GeomRef::MeshKind, i});
    }
    for (uint32_t i = 0; i < scene.spheres.size(); ++i) {
        const Sphere& s = scene.spheres[i];
        RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        float* v = static_cast<float*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1));
        v[0] = s.center.x;
        v[1] = s.center.y;
        v[2] = s.center.z;
        v[3] = s.radius;
        maybe_mask(g, scene, s.bsdf, nullptr, &s, &masked_);
        rtcCommitGeometry(g);
        uint32_t id = rtcAttachGeometry(scene_, g);
        rtcReleaseGeometry(g);
        if (id != scene.geoms.size()) throw std::runtime_error("Embree: unexpected geometry ID");
        scene.geoms.push_back({GeomRef::SphereKind, i});
    }
    rtcCommitScene(scene_);
    check(device_, "building the BVH");
}

Accel::~Accel() {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
}

bool Accel::intersect(const Ray& ray, float* t, uint32_t* geom, uint32_t* prim, float* u, float* v) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    rh.ray.org_x = ray.o.x;
    rh.ray.org_y = ray.o.y;
    rh.ray.org_z = ray.o.z;
    rh.ray.dir_x = ray.d.x;
    rh.ray.dir_y = ray.d.y;
    rh.ray.dir_z = ray.d.z;
    rh.ray.tnear = ray.tmin;
    rh.ray.tfar = ray.tmax;
    rh.ray.time = 0;
    rh.ray.mask = ~0u;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    *t = rh.ray.tfar;
    *geom = rh.hit.geomID;
    *prim = rh.hit.primID;
    *u = rh.hit.u;
    *v = rh.hit.v;
    return true;
}

bool Accel::occluded(const Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    r.org_x = ray.o.x;
    r.org_y = ray.o.y;
    r.org_z = ray.o.z;
    r.dir_x = ray.d.x;
    r.dir_y = ray.d.y;
    r.dir_z = ray.d.z;
    r.tnear = ray.tmin;
    r.tfar = ray.tmax;
    r.time = 0;
    r.mask = ~0u;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(scene_, &ctx, &r);
    return r.tfar < 0;  // Embree sets tfar = -inf on a hit
}

}  // namespace iris
