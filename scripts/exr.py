"""A small OpenEXR reader for the benchmark scripts (Debian's /usr/bin/python3 has NumPy but no EXR module):
single-part scan-line files, NONE / ZIPS / ZIP compression, HALF and FLOAT channels, which is what iris
(formats/exr.cpp: ZIP, float) and Blender (cycles_render.py: ZIP, float) write. Anything else raises.

  import exr; ch = exr.read("image.exr")   # {"R": H x W float32 array, ..., "variance.R": ...}
  rgb = exr.rgb("image.exr")               # H x W x 3, top row first
Format facts from the OpenEXR file layout document (header attributes, offset table, ZIP blocks of 16
scan lines with a byte predictor and split interleave).
"""
import struct
import zlib

import numpy as np

_LINES = {0: 1, 2: 1, 3: 16}  # compression code -> scan lines per block (NONE, ZIPS, ZIP)


def read(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError(path + ": not an OpenEXR file")
    if struct.unpack_from("<I", data, 4)[0] & 0x1a00:  # tiled, deep or multi-part (long names are fine)
        raise ValueError(path + ": only single-part scan-line EXRs are read")
    pos, attrs = 8, {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        end2 = data.index(b"\0", end + 1)
        typ = data[end + 1:end2].decode()
        size = struct.unpack_from("<i", data, end2 + 1)[0]
        attrs[name] = (typ, data[end2 + 5:end2 + 5 + size])
        pos = end2 + 5 + size
    pos += 1
    chans, raw, p = [], attrs["channels"][1], 0
    while raw[p] != 0:
        e = raw.index(b"\0", p)
        ptype, = struct.unpack_from("<i", raw, e + 1)
        xs, ys = struct.unpack_from("<ii", raw, e + 9)
        if (xs, ys) != (1, 1) or ptype not in (1, 2):
            raise ValueError(path + ": subsampled or UINT channels are not read")
        chans.append((raw[p:e].decode(), ptype))
        p = e + 17
    comp = attrs["compression"][1][0]
    if comp not in _LINES:
        raise ValueError(path + ": compression %d is not read (NONE, ZIPS, ZIP only)" % comp)
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    lpb = _LINES[comp]
    nblocks = (h + lpb - 1) // lpb
    offsets = struct.unpack_from("<%dQ" % nblocks, data, pos)
    out = {n: np.empty((h, w), np.float32) for n, _ in chans}
    for off in offsets:
        y, size = struct.unpack_from("<ii", data, off)
        block = data[off + 8:off + 8 + size]
        lines = min(lpb, y1 - y + 1)
        want = lines * w * sum(2 if t == 1 else 4 for _, t in chans)
        if comp != 0 and size < want:
            t = np.frombuffer(zlib.decompress(block), np.uint8)
            t = np.cumsum(t.astype(np.int64) - 128, dtype=np.int64)
            t = ((t + 128) % 256).astype(np.uint8)  # undo the byte predictor: d[i] = d[i-1] + t[i] - 128
            half = (len(t) + 1) // 2
            b = np.empty_like(t)
            b[0::2], b[1::2] = t[:half], t[half:]
        else:
            b = np.frombuffer(block, np.uint8)
        if len(b) != want:
            raise ValueError(path + ": a block of %d bytes, expected %d" % (len(b), want))
        p = 0
        for r in range(lines):
            for n, t in chans:
                nb = w * (2 if t == 1 else 4)
                out[n][y - y0 + r] = np.frombuffer(b[p:p + nb].tobytes(), "<f2" if t == 1 else "<f4")
                p += nb
    return out


def rgb(path):
    ch = read(path)
    return np.stack([ch["R"], ch["G"], ch["B"]], axis=2)


def variance(path):
    """The variance.R/G/B layers (iris render --variance: the variance of each pixel's mean), H x W x 3."""
    ch = read(path)
    return np.stack([ch["variance.R"], ch["variance.G"], ch["variance.B"]], axis=2)
