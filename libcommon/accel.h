// Embree wrapper: one device and one scene with all triangle meshes and spheres, built once.
// Embree reports errors through one device callback (Embree tutorial habit) that records the message;
// construction failures throw.
#pragma once

#include <embree3/rtcore.h>

#include <vector>

#include "libcommon/scene.h"

namespace iris {

// What the mask filter (accel.cpp) reads of one shape whose BSDF is a `mask` (bsdf_is_masked): the
// constant opacity, or the texture (times `opacity`) and the shape, to find the hit's uv.
struct MaskedShape {
    float opacity = 1;
    const Texture* texture = nullptr;
    const Mesh* mesh = nullptr;      // the shape: a mesh ...
    const Sphere* sphere = nullptr;  // ... or a sphere
};

// The opacity of a masked shape at a hit on triangle `prim` with Embree's barycentrics (u, v) (a mesh),
// or at point p (a sphere). In [0, 1]: the probability that a ray stops there.
float mask_opacity(const MaskedShape& m, uint32_t prim, float u, float v, Vec3 p);

// The number in [0, 1) that the filter compares with the opacity: a hash of the ray (origin and direction,
// bit for bit), the primitive (geometry and primitive IDs) and the side the ray meets it from (`back`:
// along its geometric normal; a sphere is met twice). Uniform over rays
// (tests/statistical/test_mask_irradiance.cpp), and the same each time Embree offers the same hit of the
// same ray (it may offer a hit more than once: a triangle split between BVH leaves). Why a hash and not a
// random number drawn per ray: docs/DESIGN.md, "Masks" (section 3); in short, distinct rays get
// independent fair coins as far as the estimators can tell, the image stays a function of the seed
// alone (the same for any thread count), and no ray-tracing call needs a new argument.
float mask_uniform(Vec3 o, Vec3 d, uint32_t geom, uint32_t prim, bool back);

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

    // How many shapes carry the mask filter (0 for a scene without masks: then Embree runs without any
    // filter callback, exactly as before masks existed).
    size_t masked_shapes() const { return masked_.size(); }

private:
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
    std::vector<MaskedShape> masked_;  // Embree holds pointers to these: sized once, never grown
};

}  // namespace iris
