#include "libcommon/accel.h"

#include <cstring>
#include <stdexcept>
#include <string>

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

}  // namespace

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
