// STUB: to be replaced by the real implementation.
#include "libcommon/sampling.h"
#include <stdexcept>
namespace iris {
#define IRIS_STUB throw std::logic_error(std::string("not implemented: ") + __func__)
Vec3 sample_uniform_sphere(Vec2) { IRIS_STUB; }
Vec2 invert_uniform_sphere(Vec3) { IRIS_STUB; }
Vec3 sample_uniform_hemisphere(Vec2) { IRIS_STUB; }
Vec2 invert_uniform_hemisphere(Vec3) { IRIS_STUB; }
Vec2 sample_concentric_disk(Vec2) { IRIS_STUB; }
Vec2 invert_concentric_disk(Vec2) { IRIS_STUB; }
Vec3 sample_cosine_hemisphere(Vec2) { IRIS_STUB; }
Vec2 invert_cosine_hemisphere(Vec3) { IRIS_STUB; }
Vec3 sample_uniform_cone(Vec2, float) { IRIS_STUB; }
float uniform_cone_pdf(float) { IRIS_STUB; }
Vec2 invert_uniform_cone(Vec3, float) { IRIS_STUB; }
Vec2 sample_uniform_triangle(Vec2) { IRIS_STUB; }
Vec2 invert_uniform_triangle(Vec2) { IRIS_STUB; }
Distribution1D::Distribution1D(const std::vector<float>&) { IRIS_STUB; }
uint32_t Distribution1D::sample(float, float*) const { IRIS_STUB; }
}  // namespace iris
