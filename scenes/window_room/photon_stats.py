#!/usr/bin/env python3
"""How many of a photon map's photons (trace-photons' output for window_room.xml) landed inside the room:
envmap photons start on a disk covering the whole scene, and only those that pass the window get in.
Reads the datasets with h5dump (Debian's hdf5-tools). Usage: photon_stats.py photons.h5"""
import os
import subprocess
import sys
import tempfile

import numpy as np

X, Y, Z, WALL = 4.0, 2.6, 5.0, 0.2  # as make_scene.py
WIN_Z0, WIN_Z1, WIN_Y0, WIN_Y1 = 1.9, 3.3, 0.8, 2.1


def dataset(path, name, dtype, width):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "d.bin")
        subprocess.run(["h5dump", "-d", name, "-b", "LE", "-o", out, path], check=True, stdout=subprocess.DEVNULL)
        return np.fromfile(out, dtype).reshape(-1, width) if width > 1 else np.fromfile(out, dtype)


def attribute(path, name):
    text = subprocess.run(["h5dump", "-a", name, path], check=True, capture_output=True, text=True).stdout
    return int(text.split("(0):")[1].split()[0])


def main():
    path = sys.argv[1]
    p = dataset(path, "/position", "<f4", 3)
    n = dataset(path, "/normal", "<f4", 3)
    power = dataset(path, "/power", "<f4", 3).sum(axis=1)
    bounces = dataset(path, "/bounces", "u1", 1)
    caustic = dataset(path, "/caustic", "u1", 1) == 1
    paths = attribute(path, "emitted_paths")
    # A photon is inside when a point 1 cm off its surface, on the side it arrived from, is in the air
    # of the room or of the window opening (not in the wall's solid, not outside).
    q = p + 0.01 * n
    in_box = (q[:, 0] > 0) & (q[:, 0] < X + WALL) & (q[:, 1] > 0) & (q[:, 1] < Y) & (q[:, 2] > 0) & (q[:, 2] < Z)
    in_wall = (q[:, 0] > X) & ~((q[:, 1] > WIN_Y0) & (q[:, 1] < WIN_Y1) & (q[:, 2] > WIN_Z0) & (q[:, 2] < WIN_Z1))
    inside = in_box & ~in_wall
    first = bounces == 0
    print(f"emitted paths                     {paths}")
    print(f"photons stored                    {len(p)}")
    print(f"photons inside the room           {inside.sum()} ({100 * inside.mean():.2f} % of stored)")
    print(f"paths whose first hit is inside   {(inside & first).sum()} ({100 * (inside & first).sum() / paths:.2f} % of emitted)")
    print(f"first hits outside (wasted)       {(~inside & first).sum()} ({100 * (~inside & first).sum() / paths:.2f} % of emitted)")
    print(f"photon power inside / all stored  {power[inside].sum() / power.sum():.4f}")
    print(f"caustic photons inside            {(inside & caustic).sum()} (after the glass ball; "
          f"{(inside & caustic & (bounces == 2)).sum()} of them straight from it: sun, two refractions, hit)")


if __name__ == "__main__":
    main()
