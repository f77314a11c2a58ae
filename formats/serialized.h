// Reader for Mitsuba's "serialized" mesh files (Mitsuba 0.5 documentation, the serialized shape): a
// sequence of shapes, each a little-endian uint16 format tag 0x041C and uint16 version (3 or 4)
// followed by a zlib stream holding
//   uint32 flags (0x0001 vertex normals, 0x0002 texture coordinates, 0x0008 vertex colours,
//                 0x0010 use face normals, 0x1000 single precision, 0x2000 double precision),
//   version 4 only: the shape's name, UTF-8, NUL-terminated,
//   uint64 vertex count, uint64 triangle count,
//   positions, [normals], [uvs], [colours] as floats or doubles, then the triangles' vertex indices
//   (uint32, or uint64 when there are more than 2^32 vertices);
// and, at the end of the file, a dictionary: one offset per shape from the start of the file (uint64
// in version 4, uint32 in version 3) and the uint32 number of shapes.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "formats/mesh_file.h"

namespace iris {

// Number of shapes in the file (from its end-of-file dictionary). Throws MeshFileError.
uint32_t serialized_shape_count(std::string_view bytes, const std::string& name);

// Decodes shape `index` (0-based, Mitsuba's shapeIndex). Colours are read and dropped. Throws
// MeshFileError naming `name`, the shape and what is wrong.
TriangleMesh parse_serialized(std::string_view bytes, uint32_t index, const std::string& name);

// Encodes one shape (version 4; single precision, or double), for tests and conversion tools: the
// inverse of parse_serialized. Concatenate several with serialized_dictionary to make a file.
// Version 3, as older exporters wrote it: no shape name and no precision flag (single precision;
// double_precision must be false).
std::string serialize_shape(const TriangleMesh& mesh, const std::string& shape_name, bool double_precision = false,
                            int version = 4);
// The end-of-file dictionary for shapes of the given byte sizes, written one after another (offsets of
// 64 bits in version 4, 32 in version 3).
std::string serialized_dictionary(const std::vector<size_t>& shape_sizes, int version = 4);

}  // namespace iris
