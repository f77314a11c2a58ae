#!/usr/bin/env python3
# Writes the mesh fuzzer's seeds into tests/fuzz/seeds/mesh/: a quad as ASCII PLY (normals, uvs), the same as
# big-endian binary PLY, and a two-shape Mitsuba serialized file (version 4, single precision, one
# shape with normals and uvs). Run once; the outputs are committed.
import os, struct, zlib

here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "seeds", "mesh")
pos = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
uv = [(0, 0), (1, 0), (1, 1), (0, 1)]
head = ("element vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n"
        "property float ny\nproperty float nz\nproperty float u\nproperty float v\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n")
with open(os.path.join(here, "quad_ascii.ply"), "w") as f:
    f.write("ply\nformat ascii 1.0\n" + head)
    for p, t in zip(pos, uv):
        f.write("%g %g %g 0 0 1 %g %g\n" % (p + t))
    f.write("4 0 1 2 3\n")
with open(os.path.join(here, "quad_be.ply"), "wb") as f:
    f.write(("ply\nformat binary_big_endian 1.0\n" + head).encode())
    for p, t in zip(pos, uv):
        f.write(struct.pack(">8f", *p, 0, 0, 1, *t))
    f.write(struct.pack(">B4i", 4, 0, 1, 2, 3))

def shape(flags, name, with_attrs):
    raw = struct.pack("<I", flags) + name + b"\0" + struct.pack("<QQ", 4, 2)
    raw += b"".join(struct.pack("<3f", *p) for p in pos)
    if with_attrs:
        raw += b"".join(struct.pack("<3f", 0, 0, 1) for _ in pos)
        raw += b"".join(struct.pack("<2f", *t) for t in uv)
    raw += struct.pack("<6I", 0, 1, 2, 0, 2, 3)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(raw)

a = shape(0x1000 | 0x0001 | 0x0002, b"quad", True)
b = shape(0x1000 | 0x0010, b"flat", False)
with open(os.path.join(here, "two_quads.serialized"), "wb") as f:
    f.write(a + b + struct.pack("<QQI", 0, len(a), 2))
