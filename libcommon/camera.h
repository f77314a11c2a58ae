// Mitsuba's perspective pinhole camera. Camera space: +z looks along the view direction, +x is "left"
// (lookAt's cross(up, dir)), +y is up; so the image's right is cross(dir, up) and its top is +y.
#pragma once

#include "libcommon/math.h"

namespace iris {

enum class FovAxis : uint8_t { X, Y, Diagonal, Smaller, Larger };

struct Camera {
    Transform to_world;      // camera -> world (from the <transform name="toWorld">)
    float fov_degrees = 45;  // full field of view along fov_axis
    FovAxis fov_axis = FovAxis::X;
    float near_clip = 1e-2f; // world units along the view axis; Mitsuba's nearClip
    float far_clip = 1e4f;

    // Derived (camera_prepare): world-space origin and basis, tangents of the half fields of view.
    Vec3 origin, right, up, forward;  // right = image +x, up = image -y (rows grow downwards)
    float tan_half_x = 1, tan_half_y = 1;
};

// Fills the derived fields for an image of width x height pixels.
void camera_prepare(Camera& c, int width, int height);

// World-space unit direction through film position (fx, fy) in pixels, (0,0) = top-left corner.
// The ray starts at the camera origin; the caller applies near/far clipping through tmin/tmax
// (distance along the direction = clip / cos to the view axis, as Mitsuba).
Vec3 camera_direction(const Camera& c, float fx, float fy, int width, int height);

// The inverse: film position (fx, fy) in pixels of the world direction d from the camera origin, and
// the cosine of d to the view axis; false if d points behind the camera. Film positions outside
// [0, width) x [0, height) are returned as they are (a filter reaches across the image's edge).
bool camera_film_position(const Camera& c, Vec3 d, int width, int height, float* fx, float* fy, float* cos_axis);

}  // namespace iris
