#!/usr/bin/python3
"""Measures the pixel filter of iris and of Blender Cycles (scripts/cycles_render.py) on one scene: a
slanted emitter edge (radiance 1, tilted 5 degrees, nothing else in view), seen directly. For every row
the edge position is the row's lit area (a symmetric filter conserves it); each pixel's value against its
centre's signed distance to that edge is the edge spread function, to which a Gaussian's (its CDF) is
fitted. Prints the fitted standard deviation in pixels and the binned profile of each render.

  python3 -m scripts.bench filter-profile [--filter gaussian|box] [--spp 256] [--cycles-width W ...]

Needs build/bin (IRIS_BIN) and blender (BLENDER). Exit 1 when iris's and Cycles' default-mapped fitted
sigmas differ by more than 3 %. The commands come from the harness's tools module.
"""
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

from . import tools
from .. import exr

SCENE = """<?xml version="1.0" encoding="utf-8"?>
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="1"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="20"/>
    <transform name="toWorld"><lookAt origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="64"/></sampler>
    <film type="hdrfilm"><integer name="width" value="96"/><integer name="height" value="96"/>
      <rfilter type="%s"/></film>
  </sensor>
  <bsdf type="diffuse" id="black"><rgb name="reflectance" value="0, 0, 0"/></bsdf>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="10" y="10" z="1"/><translate x="-10" y="0" z="0"/>
      <rotate z="1" angle="5"/></transform>
    <ref id="black"/>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
</scene>
"""


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("filter_profile: error: %s failed:\n%s" % (" ".join(cmd), p.stderr[-2000:]))


def esf(d, s):
    """Fraction of a Gaussian filter of standard deviation s (px) on the lit side, d px past the edge."""
    return 0.5 * (1.0 - np.vectorize(math.erf)(d / (s * math.sqrt(2.0))))


def fit(a):
    a = a.mean(axis=2)
    h, w = a.shape
    if a[:, :5].mean() < a[:, -5:].mean():
        a = a[:, ::-1]
    L = np.median(a[:, :10])
    rows = np.arange(h) + 0.5
    k, c = np.polyfit(rows, a.sum(axis=1) / L, 1)  # edge position (px from the left) per row, a line
    d = (np.arange(w)[None, :] + 0.5 - (k * rows[:, None] + c)) / math.sqrt(1 + k * k)
    v, m = a / L, np.abs(d) < 4
    err, s = min((float(np.mean((v[m] - esf(d[m], s)) ** 2)), s) for s in np.arange(0.2, 2.5, 0.0025))
    prof = [float(v[(d >= b - 0.125) & (d < b + 0.125)].mean()) for b in np.arange(-2, 2.01, 0.5)]
    return s, math.sqrt(err), prof


def add_options(p):
    p.add_argument("--filter", default="gaussian", choices=("gaussian", "box"))
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--cycles-width", type=float, action="append", default=[],
                   help="also render Cycles with this filter width (px), e.g. 6 = the old mapping")
    p.add_argument("-o", "--output", default="", help="also write what it prints to this file")


def profile(a):
    """Prints (and returns) the fitted sigmas and profiles; the ratio Cycles / iris."""
    lines = []
    with tempfile.TemporaryDirectory() as t:
        xml, js = os.path.join(t, "edge.xml"), os.path.join(t, "edge.json")
        with open(xml, "w") as f:
            f.write(SCENE % a.filter)
        run(tools.export_scene_cmd(xml, js))
        runs = [("iris", os.path.join(t, "iris.exr"))]
        run(tools.render_cmd(xml, runs[0][1], spp=a.spp))
        for wdt in [None] + a.cycles_width:
            label = "cycles" if wdt is None else "cycles width %g" % wdt
            out = os.path.join(t, "cycles%s.exr" % ("" if wdt is None else "-%g" % wdt))
            run(tools.cycles_cmd(js, out, spp=a.spp, filter_width=wdt))
            runs.append((label, out))
        sig = {}
        lines.append("filter %s, %d spp; profile = value at distances -2..2 px (step 0.5) from the edge"
                     % (a.filter, a.spp))
        for label, path in runs:
            s, rms, prof = fit(exr.rgb(path))
            sig[label] = s
            lines.append("  %-16s fitted sigma %.3f px (rms residual %.4f)  profile %s"
                         % (label, s, rms, " ".join("%.3f" % x for x in prof)))
    lines.append("  Cycles / iris fitted sigma: %.3f" % (sig["cycles"] / sig["iris"]))
    print("\n".join(lines))
    return sig["cycles"] / sig["iris"], "\n".join(lines)


def cmd_filter_profile(a):
    r, text = profile(a)
    if a.output:
        tools_write(a.output, text + "\n")
    sys.exit(1 if abs(r - 1) > 0.03 else 0)


def tools_write(path, text):
    from .measure import write_text
    write_text(path, text)
