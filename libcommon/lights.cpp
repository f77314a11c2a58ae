// STUB: to be replaced by the real implementation.
#include "libcommon/lights.h"
#include "libcommon/scene.h"
#include <stdexcept>
#include <string>
namespace iris {
#define IRIS_STUB throw std::logic_error(std::string("not implemented: ") + __func__)
RGB light_emitted(const Light&, Vec3, Vec3) { IRIS_STUB; }
RGB light_power(const Scene&, const Light&) { IRIS_STUB; }
void lights_prepare(Scene&) { IRIS_STUB; }
bool sample_light(const Scene&, Vec3, float, Vec2, LightSample*) { IRIS_STUB; }
float light_pdf(const Scene&, uint32_t, Vec3, Vec3, Vec3, Vec3) { IRIS_STUB; }
float light_selection_pmf(const Scene&, uint32_t) { IRIS_STUB; }
}  // namespace iris
