// Stanford PLY reader (ASCII, binary little- and big-endian): vertex positions, normals (nx ny nz) and
// texture coordinates (u v, s t, texture_u texture_v, texture_s texture_t), and faces given as lists
// of vertex indices (vertex_indices or vertex_index), triangulated as fans. Other elements and
// properties (colours, edges, materials) are read past and not used.
//
// Why not a library: Debian has no tinyply or rply, and assimp (libassimp-dev 5.2.5, tried) segfaults
// on a truncated binary PLY and loads a truncated ASCII one as a face with one corner, without an
// error. This reader checks every count, index and number and names the file and the line (ASCII) or
// byte offset (binary). It makes no allocation per vertex or face: the data are decoded straight into
// the output arrays.
#pragma once

#include <string>
#include <string_view>

#include "formats/mesh_file.h"

namespace iris {

// Parses a PLY file's bytes. `name` prefixes error messages. Throws MeshFileError.
TriangleMesh parse_ply(std::string_view bytes, const std::string& name);

}  // namespace iris
