#!/usr/bin/env python3
"""Writes the meshes of door.xml (metres): two rooms side by side along x, joined only by a door in
the wall between them; the light is on the ceiling of the far room. Run from this folder."""


def quad(verts, faces, a, b, c, d):
    """Quad a-b-c-d, counter-clockwise seen from the side its normal faces."""
    base = len(verts) + 1
    verts += [a, b, c, d]
    faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]


def box(verts, faces, lo, hi):
    """Axis-aligned box, faces outward."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    quad(verts, faces, (x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1))  # +x
    quad(verts, faces, (x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0))  # -x
    quad(verts, faces, (x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0))  # +y
    quad(verts, faces, (x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1))  # -y
    quad(verts, faces, (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1))  # +z
    quad(verts, faces, (x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0))  # -z


def write(name, verts, faces):
    with open(name, "w") as f:
        f.write("# written by make_meshes.py\n")
        for v in verts:
            f.write("v %g %g %g\n" % v)
        for t in faces:
            f.write("f %d %d %d\n" % t)


X, Y, Z = 8.2, 3.0, 4.0  # both rooms together
WALL0, WALL1 = 4.0, 4.2  # the wall between them
DOOR_Z0, DOOR_Z1, DOOR_Y = 1.6, 2.4, 2.1  # the door's sides and top

# The shell: floor, ceiling and the outer walls, facing inwards.
v, f = [], []
quad(v, f, (0, 0, 0), (0, 0, Z), (X, 0, Z), (X, 0, 0))  # floor, +y
quad(v, f, (0, Y, 0), (X, Y, 0), (X, Y, Z), (0, Y, Z))  # ceiling, -y
quad(v, f, (0, 0, 0), (0, Y, 0), (0, Y, Z), (0, 0, Z))  # x = 0, +x
quad(v, f, (X, 0, 0), (X, 0, Z), (X, Y, Z), (X, Y, 0))  # x = X, -x
quad(v, f, (0, 0, 0), (X, 0, 0), (X, Y, 0), (0, Y, 0))  # z = 0, +z
quad(v, f, (0, 0, Z), (0, Y, Z), (X, Y, Z), (X, 0, Z))  # z = Z, -z
write("meshes/shell.obj", v, f)

# The wall between the rooms, around the door.
v, f = [], []
box(v, f, (WALL0, 0, 0), (WALL1, Y, DOOR_Z0))
box(v, f, (WALL0, 0, DOOR_Z1), (WALL1, Y, Z))
box(v, f, (WALL0, DOOR_Y, DOOR_Z0), (WALL1, Y, DOOR_Z1))
write("meshes/wall.obj", v, f)

# The light: a 0.6 m square just below the far room's ceiling, facing down, near its far corner.
v, f = [], []
quad(v, f, (7.3, 2.99, 0.3), (7.9, 2.99, 0.3), (7.9, 2.99, 0.9), (7.3, 2.99, 0.9))
write("meshes/light.obj", v, f)
