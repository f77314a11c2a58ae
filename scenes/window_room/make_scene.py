#!/usr/bin/env python3
"""Writes everything window_room.xml reads, procedurally and deterministically (numpy and Pillow, which
Debian's python3-matplotlib depends on; run from this folder with /usr/bin/python3):

  meshes/*.ply        binary little-endian PLY, positions in metres, normals and (u, v) per vertex
  textures/wood.jpg   floor planks, 512 x 512, sRGB           (uv in metres x 0.5: one tile is 2 m)
  textures/plaster.png  wall plaster, 256 x 256, sRGB        (uv in metres x 0.5)
  sky.exr             equirectangular sky with a sun, 256 x 128, half floats, ZIP compression

The room: 4 m (x) x 2.6 m (y, up) x 5 m (z), the window in the wall at x = 4 (0.2 m thick), a table in
front of it with a glass ball on it; the sun (35 degrees above the horizon) shines through the window
onto the table, the ball and the floor. The sky's orientation comes from the emitter's toWorld (a
rotation about y by SKY_ROTATION degrees), so the sun is stored at the direction that rotation maps onto
SUN_WORLD.
"""
import struct
import zlib

import numpy as np
from PIL import Image

X, Y, Z = 4.0, 2.6, 5.0  # the room's inside, metres
WALL = 0.2  # thickness of the window wall (x from X to X + WALL)
WIN_Z0, WIN_Z1, WIN_Y0, WIN_Y1 = 1.9, 3.3, 0.8, 2.1  # the window opening
TABLE_X0, TABLE_X1, TABLE_Z0, TABLE_Z1 = 2.4, 3.6, 2.05, 2.95
TABLE_Y0, TABLE_Y1 = 0.72, 0.76  # the top's underside and top, metres
LEG = 0.06  # square legs, metres
BALL_R = 0.14
BALL_C = (3.0, TABLE_Y1 + BALL_R, 2.5)

SUN_ELEVATION, SUN_AZIMUTH = 35.0, 20.0  # degrees; azimuth from +x towards +z
SUN_RADIUS = 3.0  # degrees; the real sun's is 0.27, but a wider, dimmer disk (same irradiance) keeps the
# fireflies of paths that reach it through the glass ball within what a 2-core reference can average
# W/(m^2 sr) in the map's units: normal irradiance 1850 x 0.0086 sr = 16, ~5x the sky's on a horizontal surface
SUN_RADIANCE = np.array([1.0, 0.92, 0.80]) * 1850.0
SKY_ROTATION = 30.0  # degrees about +y, the emitter's toWorld (written into window_room.xml by hand)


# ---- meshes ---------------------------------------------------------------------------------------
class Mesh:
    def __init__(self):
        self.p, self.n, self.uv, self.f = [], [], [], []

    def quad(self, a, b, c, d, uv_axes):
        """Quad a-b-c-d, counter-clockwise seen from the side it faces; uv = its vertices' coordinates
        uv_axes (two of 0, 1, 2 = x, y, z), in metres (the XML's uscale/vscale size the textures)."""
        a, b, c, d = (np.array(v, float) for v in (a, b, c, d))
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n)
        base = len(self.p)
        for v in (a, b, c, d):
            self.p.append(v)
            self.n.append(n)
            self.uv.append([v[ax] for ax in uv_axes])
        self.f += [(base, base + 1, base + 2), (base, base + 2, base + 3)]

    def box(self, lo, hi, faces="xXyYzZ"):
        """Axis-aligned box facing outward; `faces` picks the sides (x = -x side, X = +x side, ...)."""
        x0, y0, z0 = lo
        x1, y1, z1 = hi
        if "X" in faces: self.quad((x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1), (2, 1))
        if "x" in faces: self.quad((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0), (2, 1))
        if "Y" in faces: self.quad((x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (0, 2))
        if "y" in faces: self.quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1), (0, 2))
        if "Z" in faces: self.quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1), (0, 1))
        if "z" in faces: self.quad((x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0), (0, 1))

    def write(self, name):
        nv, nf = len(self.p), len(self.f)
        header = ("ply\nformat binary_little_endian 1.0\ncomment written by make_scene.py (metres)\n"
                  f"element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
                  "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
                  f"element face {nf}\nproperty list uchar int vertex_indices\nend_header\n")
        verts = np.hstack([np.array(self.p), np.array(self.n), np.array(self.uv)]).astype("<f4")
        faces = np.zeros(nf, dtype=[("k", "u1"), ("i", "<i4", (3,))])
        faces["k"] = 3
        faces["i"] = np.array(self.f)
        with open(name, "wb") as out:
            out.write(header.encode("ascii"))
            out.write(verts.tobytes())
            out.write(faces.tobytes())


def sphere(center, r, n_theta=24, n_phi=48):
    """A UV sphere with smooth normals (outward), uv = (longitude, latitude) in [0, 1]."""
    m = Mesh()
    c = np.array(center, float)
    for i in range(n_theta + 1):
        th = np.pi * i / n_theta
        for j in range(n_phi + 1):
            ph = 2 * np.pi * j / n_phi
            d = np.array([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)])
            m.p.append(c + r * d)
            m.n.append(d)
            m.uv.append([j / n_phi, i / n_theta])
    row = n_phi + 1
    for i in range(n_theta):
        for j in range(n_phi):
            a, b = i * row + j, i * row + j + 1
            c2, d2 = (i + 1) * row + j + 1, (i + 1) * row + j
            # Counter-clockwise seen from outside; no slivers at the poles.
            if i > 0: m.f.append((a, b, d2))
            if i < n_theta - 1: m.f.append((b, c2, d2))
    return m


def write_meshes():
    # Floor and ceiling run under / over the window wall; the walls face into the room.
    m = Mesh()
    m.quad((0, 0, 0), (0, 0, Z), (X + WALL, 0, Z), (X + WALL, 0, 0), (0, 2))
    m.write("meshes/floor.ply")
    m = Mesh()
    m.quad((0, Y, 0), (X + WALL, Y, 0), (X + WALL, Y, Z), (0, Y, Z), (0, 2))
    m.write("meshes/ceiling.ply")
    m = Mesh()
    m.quad((0, 0, 0), (0, Y, 0), (0, Y, Z), (0, 0, Z), (2, 1))  # x = 0, facing +x
    m.quad((0, 0, 0), (X + WALL, 0, 0), (X + WALL, Y, 0), (0, Y, 0), (0, 1))  # z = 0, facing +z
    m.quad((0, 0, Z), (0, Y, Z), (X + WALL, Y, Z), (X + WALL, 0, Z), (0, 1))  # z = Z, facing -z
    # The window wall: four boxes around the opening (their faces inside the opening are its reveal).
    x0, x1 = X, X + WALL
    m.box((x0, 0, 0), (x1, Y, WIN_Z0), "xXZ")
    m.box((x0, 0, WIN_Z1), (x1, Y, Z), "xXz")
    m.box((x0, 0, WIN_Z0), (x1, WIN_Y0, WIN_Z1), "xXY")
    m.box((x0, WIN_Y1, WIN_Z0), (x1, Y, WIN_Z1), "xXy")
    m.write("meshes/walls.ply")
    # The table: a top (checkerboard) and four legs.
    m = Mesh()
    m.box((TABLE_X0, TABLE_Y0, TABLE_Z0), (TABLE_X1, TABLE_Y1, TABLE_Z1))
    m.write("meshes/table_top.ply")
    m = Mesh()
    for lx in (TABLE_X0 + 0.05, TABLE_X1 - 0.05 - LEG):
        for lz in (TABLE_Z0 + 0.05, TABLE_Z1 - 0.05 - LEG):
            m.box((lx, 0, lz), (lx + LEG, TABLE_Y0, lz + LEG), "xXzZ")
    m.write("meshes/table_legs.ply")
    sphere(BALL_C, BALL_R).write("meshes/ball.ply")


# ---- textures -------------------------------------------------------------------------------------
def periodic_noise(rng, n, scale):
    """Tileable smooth noise on an n x n grid: white noise low-passed (Gaussian, `scale` texels) by FFT,
    normalised to unit standard deviation."""
    w = rng.standard_normal((n, n))
    k = np.fft.fftfreq(n)
    kk = k[:, None] ** 2 + k[None, :] ** 2
    s = np.real(np.fft.ifft2(np.fft.fft2(w) * np.exp(-2 * (np.pi * scale) ** 2 * kk)))
    return s / s.std()


def srgb_bytes(linear):
    c = np.clip(linear, 0, 1)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return np.round(s * 255).astype(np.uint8)


def write_textures():
    rng = np.random.default_rng(27)
    # Wood: 8 planks across the tile (v), each 25 cm wide, with an end joint at a random u; grain along u.
    n = 512
    u = np.arange(n)[None, :] / n
    v = np.arange(n)[:, None] / n
    plank = np.floor(v * 8).astype(int)
    joint = rng.random(8)[plank]
    seg = np.floor(u - joint + 1).astype(int)  # which board along the plank (0 or 1)
    tone = rng.uniform(0.75, 1.15, (8, 2))[plank, seg % 2]
    grain = 0.5 + 0.5 * np.sin(2 * np.pi * (v * 8 * 6 + 0.8 * periodic_noise(rng, n, 20)))
    fine = periodic_noise(rng, n, 1.5)
    base = np.array([0.42, 0.24, 0.11])
    refl = base * (tone * (0.85 + 0.15 * grain + 0.03 * fine))[..., None]
    seam = (np.minimum((v * 8) % 1, 1 - (v * 8) % 1) < 0.006) | (np.minimum((u - joint) % 1, 1 - (u - joint) % 1) < 0.003)
    refl[seam] *= 0.35
    Image.fromarray(srgb_bytes(refl)).save("textures/wood.jpg", quality=88)
    # Plaster: warm white with a faint mottling.
    n = 256
    mott = 0.04 * periodic_noise(rng, n, 12) + 0.015 * periodic_noise(rng, n, 1.0)
    refl = np.array([0.78, 0.74, 0.66]) * (1 + mott)[..., None]
    Image.fromarray(srgb_bytes(refl)).save("textures/plaster.png", optimize=True)


# ---- the sky --------------------------------------------------------------------------------------
def rot_y(deg):
    t = np.radians(deg)
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def sky_image(w, h):
    """The map in its own frame, by iris's (Mitsuba 0.5's) convention: texel (col, row) is the direction
    (sin phi sin theta, cos theta, -cos phi sin theta), phi = 2 pi (col + 0.5) / w, theta = pi (row + 0.5) / h.
    4 x 4 samples per texel, so the sun's disk is anti-aliased."""
    ss = 4
    cols = (np.arange(w * ss) + 0.5) / (w * ss)
    rows = (np.arange(h * ss) + 0.5) / (h * ss)
    phi = 2 * np.pi * cols[None, :]
    th = np.pi * rows[:, None]
    d = np.stack(np.broadcast_arrays(np.sin(phi) * np.sin(th), np.cos(th), -np.cos(phi) * np.sin(th)), -1)
    e, a = np.radians(SUN_ELEVATION), np.radians(SUN_AZIMUTH)
    sun_world = np.array([np.cos(e) * np.cos(a), np.sin(e), np.cos(e) * np.sin(a)])
    sun = rot_y(SKY_ROTATION).T @ sun_world  # toWorld maps it back onto sun_world
    cos_sun = d @ sun
    up = d[..., 1]
    t = np.clip(up, 0, 1)[..., None]
    zenith, horizon = np.array([0.20, 0.38, 0.85]), np.array([0.75, 0.85, 1.0])
    sky = horizon + (zenith - horizon) * t ** 0.5
    # A glow around the sun (forward scattering), and a ground of brown earth below the horizon.
    sky = sky * (1 + 2.5 * np.exp((cos_sun[..., None] - 1) / 0.02))
    ground = np.array([0.16, 0.13, 0.10])
    blend = np.clip(up / 0.02 + 0.5, 0, 1)[..., None]  # a soft horizon, ~1 degree
    img = ground + (sky - ground) * blend
    img = img + SUN_RADIANCE * (cos_sun > np.cos(np.radians(SUN_RADIUS)))[..., None]
    return img.reshape(h, ss, w, ss, 3).mean(axis=(1, 3))


def write_exr(name, img, compress=True):
    """A scanline OpenEXR file of half-float B, G, R channels (alphabetical, as the format asks), ZIP
    compression (16 lines per chunk: bytes split into even/odd halves, delta-coded, deflated) or none."""
    h, w, _ = img.shape
    half = img.astype("<f2")
    if not np.all(np.isfinite(half)):
        raise SystemExit("make_scene.py: the sky overflows half floats")

    def attr(name, typ, data):
        return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(data)) + data

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in "BGR") + b"\0"
    lines = 16 if compress else 1
    header = (struct.pack("<ii", 20000630, 2) +
              attr("channels", "chlist", chlist) +
              attr("compression", "compression", bytes([3 if compress else 0])) +
              attr("dataWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1)) +
              attr("displayWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1)) +
              attr("lineOrder", "lineOrder", b"\0") +
              attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
              attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    chunks = []
    for y0 in range(0, h, lines):
        raw = b"".join(half[y, :, c].tobytes() for y in range(y0, min(y0 + lines, h)) for c in (2, 1, 0))
        data = raw
        if compress:
            b = np.frombuffer(raw, np.uint8)
            t = np.concatenate([b[0::2], b[1::2]]).astype(np.int32)
            t[1:] = (t[1:] - t[:-1] + 128) & 0xFF
            z = zlib.compress(t.astype(np.uint8).tobytes(), 9)
            if len(z) < len(raw):  # otherwise the chunk is stored as it is, which readers expect
                data = z
        chunks.append(struct.pack("<ii", y0, len(data)) + data)
    offset = len(header) + 8 * len(chunks)
    table = b""
    for c in chunks:
        table += struct.pack("<Q", offset)
        offset += len(c)
    with open(name, "wb") as out:
        out.write(header + table + b"".join(chunks))


if __name__ == "__main__":
    import os
    import sys
    os.makedirs("meshes", exist_ok=True)
    os.makedirs("textures", exist_ok=True)
    write_meshes()
    write_textures()
    sky = sky_image(256, 128)
    write_exr("sky.exr", sky)
    if len(sys.argv) > 1 and sys.argv[1] == "--raw-sky":  # an uncompressed copy, to check the ZIP chunks
        write_exr(sys.argv[2], sky, compress=False)
