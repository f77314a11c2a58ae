#include "libcommon/camera.h"

namespace iris {

void camera_prepare(Camera& c, int width, int height) {
    c.origin = c.to_world.point(Vec3(0, 0, 0));
    Vec3 left = normalize(c.to_world.vector(Vec3(1, 0, 0)));
    c.up = normalize(c.to_world.vector(Vec3(0, 1, 0)));
    c.forward = normalize(c.to_world.vector(Vec3(0, 0, 1)));
    c.right = -left;
    // Mitsuba maps the fov to the chosen axis and derives the other from the aspect ratio.
    float aspect = float(width) / float(height);
    float t = std::tan(0.5f * c.fov_degrees * kPi / 180.0f);
    FovAxis axis = c.fov_axis;
    if (axis == FovAxis::Smaller) axis = aspect > 1 ? FovAxis::Y : FovAxis::X;
    if (axis == FovAxis::Larger) axis = aspect > 1 ? FovAxis::X : FovAxis::Y;
    switch (axis) {
        case FovAxis::X: c.tan_half_x = t; c.tan_half_y = t / aspect; break;
        case FovAxis::Y: c.tan_half_y = t; c.tan_half_x = t * aspect; break;
        default: {  // diagonal
            float d = std::sqrt(aspect * aspect + 1.0f);
            c.tan_half_x = t * aspect / d;
            c.tan_half_y = t / d;
        }
    }
}

Vec3 camera_direction(const Camera& c, float fx, float fy, int width, int height) {
    float x = (2.0f * fx / float(width) - 1.0f) * c.tan_half_x;   // +x = image right
    float y = (1.0f - 2.0f * fy / float(height)) * c.tan_half_y;  // +y = image top
    return normalize(c.forward + c.right * x + c.up * y);
}

bool camera_film_position(const Camera& c, Vec3 d, int width, int height, float* fx, float* fy, float* cos_axis) {
    const float z = dot(d, c.forward);
    if (!(z > 0)) return false;
    const float len = length(d);
    *cos_axis = z / len;
    *fx = (dot(d, c.right) / z / c.tan_half_x + 1) * 0.5f * float(width);
    *fy = (1 - dot(d, c.up) / z / c.tan_half_y) * 0.5f * float(height);
    return true;
}

}  // namespace iris
