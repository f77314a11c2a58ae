// Embree wrapper: one device and one scene with all triangle meshes and spheres, built once.
// Embree reports errors through one device callback (Embree tutorial habit) that records the message;
// construction failures throw.
#pragma once

#include <embree3/rtcore.h>

#include "libcommon/scene.h"

namespace iris {

class Accel {
public:
    explicit Accel(Scene& scene);
    ~Accel();
    Accel(const Accel&) = delete;
    Accel& operator=(const Accel&) = delete;

    // Closest hit; fills t, geometry and primitive IDs and barycentrics u, v. False on a miss.
    bool intersect(const Ray& ray, float* t, uint32_t* geom, uint32_t* prim, float* u, float* v) const;
    bool occluded(const Ray& ray) const;

    RTCDevice device() const { return device_; }
    RTCScene handle() const { return scene_; }

private:
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
};

}  // namespace iris
