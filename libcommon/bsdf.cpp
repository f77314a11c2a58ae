// STUB: to be replaced by the real implementation.
#include "libcommon/bsdf.h"
#include <stdexcept>
#include <string>
namespace iris {
#define IRIS_STUB throw std::logic_error(std::string("not implemented: ") + __func__)
void bsdf_prepare(Bsdf&) { IRIS_STUB; }
RGB bsdf_eval(const Bsdf&, Vec3, Vec3, TransportMode) { IRIS_STUB; }
float bsdf_pdf(const Bsdf&, Vec3, Vec3) { IRIS_STUB; }
bool bsdf_sample(const Bsdf&, Vec3, Vec2, float, BsdfSample*, TransportMode) { IRIS_STUB; }
bool bsdf_is_delta(const Bsdf&) { IRIS_STUB; }
float fresnel_dielectric(float, float, float*) { IRIS_STUB; }
RGB fresnel_conductor(float, RGB, RGB) { IRIS_STUB; }
float fresnel_diffuse_reflectance(float) { IRIS_STUB; }
}  // namespace iris
