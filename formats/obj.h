// Wavefront OBJ reader: positions, normals and polygon faces, exactly as written in the file.
//
// Why not tinyobjloader: its number parser silently turns anything it cannot read ("nan", "inf",
// "1.0.2", "abc") into 0 and rounds decimals inexactly, so a corrupt mesh would load as a different
// mesh without a word. This reader parses with std::from_chars (correctly rounded), rejects
// non-finite and malformed numbers and out-of-range indices, and names the file and line.
// Triangulation, transformation and normal handling are the scene loader's business.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "libcommon/math.h"

namespace iris {

// Thrown for malformed OBJ text; what() is "NAME:LINE: message".
struct ObjError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct ObjMesh {
    // One face corner: 0-based indices into positions, texture coordinates and normals (-1: none given).
    struct Corner {
        uint32_t v;
        int32_t n;
        int32_t t = -1;
    };
    std::vector<Vec3> positions;        // "v" records, object space (a 4th "w" or colour values are ignored)
    std::vector<Vec3> normals;          // "vn" records, as written (not normalised)
    std::vector<Vec2> texcoords;        // "vt" records (u, v) as written: v = 0 at the image's bottom (OBJ's
                                        // convention; the scene loader applies Mitsuba's flipTexCoords)
    std::vector<Corner> corners;        // the corners of all faces, face after face
    std::vector<uint32_t> face_sizes;   // corners per face, each >= 3
    std::vector<uint32_t> face_lines;   // 1-based line of each face in the file, for messages
};

// Parses OBJ text. `name` prefixes error messages. Statements that carry no geometry iris uses
// (vp, o, g, s, usemtl, mtllib, l, p, ...) are skipped; unknown statements are errors.
ObjMesh parse_obj(std::string_view text, const std::string& name);

}  // namespace iris
