"""Converts OpenEXR images to NumPy .npy arrays (float32, H x W x 3, top row first), with Blender's Python:
Debian's /usr/bin/python3 has NumPy but no EXR reader, Blender has both.

  blender -b --factory-startup -P scripts/exr_to_npy.py -- a.exr a.npy [b.exr b.npy ...]
"""
import os
import sys

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not args or len(args) % 2:
    print("exr_to_npy: error: usage: -- in.exr out.npy [in.exr out.npy ...]", file=sys.stderr)
    sys.exit(1)
for src, dst in zip(args[0::2], args[1::2]):
    try:
        img = bpy.data.images.load(os.path.abspath(src))
    except RuntimeError as e:
        print("exr_to_npy: error: %s: %s" % (src, e), file=sys.stderr)
        sys.exit(1)
    # Float EXRs stay linear in Blender (no view transform is applied to .pixels); channels RGBA.
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    a = px.reshape(h, w, 4)[::-1, :, :3].copy()  # Blender stores rows bottom to top
    tmp = dst + ".tmp.npy"
    np.save(tmp, a)
    os.replace(tmp, dst)
    bpy.data.images.remove(img)
