// STUB: to be replaced by the real implementation.
#include "libcommon/spectrum.h"
#include <stdexcept>
namespace iris {
#define IRIS_STUB throw std::logic_error(std::string("not implemented: ") + __func__)
RGB spectrum_to_rgb(const std::vector<float>&, const std::vector<float>&) { IRIS_STUB; }
RGB spectrum_to_rgb_exact(const std::vector<float>&, const std::vector<float>&) { IRIS_STUB; }
RGB xyz_to_linear_srgb(float, float, float) { IRIS_STUB; }
float srgb_to_linear(float) { IRIS_STUB; }
float linear_to_srgb(float) { IRIS_STUB; }
bool conductor_ior(const std::string&, RGB*, RGB*) { IRIS_STUB; }
bool dielectric_ior(const std::string&, float*) { IRIS_STUB; }
}  // namespace iris
