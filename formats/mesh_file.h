// The triangle mesh that the binary mesh readers (PLY, Mitsuba serialized) hand to the scene loader:
// object-space, indexed, already triangulated. Transformation, normal generation and degenerate-triangle
// handling are the scene loader's business, as for OBJ.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "libcommon/math.h"

namespace iris {

// Thrown for a malformed mesh file; what() is one line naming the file (and the line or byte offset).
struct MeshFileError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct TriangleMesh {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;      // per vertex, as stored (empty = none in the file)
    std::vector<Vec2> uvs;          // per vertex (empty = none in the file)
    std::vector<uint32_t> indices;  // 3 per triangle, each < positions.size()
    bool face_normals = false;      // the file asks for flat shading (serialized's face-normal flag)
};

}  // namespace iris
