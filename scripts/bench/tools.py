"""Every command the harness runs, built in one place: one function per tool (the tools' command line of
this round: everyday flags, everything else `--set NAME=VALUE`). When a tool's command line changes, the
function here is the one thing to adapt.

Also the few readings of the tools' output every benchmark shares: timed runs, image metadata,
compare-images' figures, the preprocessing (trace-photons -> place-caches -> fill-caches, each timed).
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import time

BIN = os.environ.get("IRIS_BIN", "build/bin")
BLENDER = os.environ.get("BLENDER", "blender")
HERE = os.path.dirname(os.path.abspath(__file__))
CYCLES_SCRIPT = os.path.join(os.path.dirname(HERE), "cycles_render.py")

# Which stage reads a preprocessing setting (PLAN's settings table), so that one flat list of
# name=value pairs (bench's --prep-set) reaches the right tools. min-caustic-share is read by two.
STAGES = {
    "photon-count": ("trace-photons",), "photon-paths": ("trace-photons",), "photon-depth": ("trace-photons",),
    "photon-rr-depth": ("trace-photons",), "photon-cutoff": ("trace-photons",),
    "min-caustic-share": ("trace-photons", "place-caches"),
    "cache-count": ("place-caches",), "camera-stride": ("place-caches",), "reach-paths": ("place-caches",),
    "gather-count": ("fill-caches",), "map-resolution": ("fill-caches",), "filter-sigma": ("fill-caches",),
    "floor": ("fill-caches",), "max-radius": ("fill-caches",), "min-photons": ("fill-caches",),
    "direct-photons": ("fill-caches",),
}


def sets(settings):
    """--set flags for a list of 'name=value' strings."""
    out = []
    for s in settings:
        if "=" not in s:
            raise ValueError("a setting is name=value, got %r" % s)
        out += ["--set", s]
    return out


def common(seed=None, threads=None):
    """The everyday flags every stage tool shares; -q always (the harness prints its own lines)."""
    out = ["-q"]
    if seed is not None:
        out += ["--seed", str(seed)]
    if threads:
        out += ["-t", str(threads)]
    return out


def trace_photons_cmd(scene, out, settings=(), seed=None, threads=None, bin_dir=None):
    return [(bin_dir or BIN) + "/trace-photons", scene, "-o", out, "--no-scene-warnings"] + common(seed, threads) \
        + sets(settings)


def place_caches_cmd(scene, photon_map, out, resolution=None, settings=(), seed=None, threads=None, bin_dir=None):
    cmd = [(bin_dir or BIN) + "/place-caches", scene, "--photon-map", photon_map, "-o", out, "--no-scene-warnings"]
    if resolution:
        cmd += ["--resolution", resolution]
    return cmd + common(seed, threads) + sets(settings)


def fill_caches_cmd(caches, photon_map, out, settings=(), seed=None, threads=None, bin_dir=None):
    return [(bin_dir or BIN) + "/fill-caches", caches, "--photon-map", photon_map, "-o", out] \
        + common(seed, threads) + sets(settings)


def render_cmd(scene, out, atlas=None, spp=None, seconds=None, resolution=None, seed=None, threads=None,
               variance=False, settings=(), bin_dir=None):
    """One render: --spp N or --time SECONDS (exactly one), settings as --set."""
    if (spp is None) == (seconds is None):
        raise ValueError("render_cmd: give spp or seconds")
    cmd = [(bin_dir or BIN) + "/render", scene, "-o", out, "--no-scene-warnings"]
    if atlas:
        cmd += ["--atlas", atlas]
    cmd += ["--spp", str(spp)] if spp is not None else ["--time", "%.3f" % seconds]
    if resolution:
        cmd += ["--resolution", resolution]
    if variance:
        cmd.append("--variance")
    return cmd + common(seed, threads) + sets(settings)


def compare_cmd(test, ref=None, json_out=False, metadata=False, masks=(), srgb_png=None, crop=None):
    cmd = [BIN + "/compare-images", test] + ([ref] if ref else [])
    if json_out:
        cmd.append("--json")
    if metadata:
        cmd.append("--metadata")
    for m in masks:
        cmd += ["--mask", m]
    if srgb_png:
        cmd += ["--srgb-png", srgb_png]
    if crop:
        cmd += ["--crop", crop]
    return cmd


def inspect_caches_cmd(atlas):
    return [BIN + "/inspect-caches", atlas]


def export_scene_cmd(scene, out, resolution=None):
    return [BIN + "/export-scene", scene, "-o", out] + (["--resolution", resolution] if resolution else [])


def bench_rays_cmd(scene, rays, repeats):
    return [BIN + "/bench-rays", scene, "--rays", str(rays), "--repeats", str(repeats)]


def cycles_cmd(scene_json, out, seconds=None, spp=None, seed=7, threads=2, filter_width=None):
    """Blender Cycles (scripts/cycles_render.py inside Blender), --time SECONDS or --spp N."""
    cmd = [BLENDER, "-b", "--factory-startup", "-t", str(threads), "-P", CYCLES_SCRIPT, "--", scene_json, out,
           "--threads", str(threads), "--seed", str(seed)]
    cmd += ["--time", "%.3f" % seconds] if seconds is not None else ["--spp", str(spp)]
    if filter_width is not None:
        cmd += ["--filter-width", "%g" % filter_width]
    return cmd


# ---- the benchmark's modes as render settings ------------------------------------------------------
# nee+bsdf: the unguided path tracer (no atlas). auto: the default with an atlas (the pilot decides).
# A fixed guided technique: the atlas without the pilot.
MODES = ("nee+bsdf", "auto", "nee+bsdf+cache", "nee+cache", "bsdf+cache")


def mode_settings(mode):
    """(needs an atlas, render settings) of a benchmark mode."""
    if mode == "nee+bsdf":
        return False, ["mode=nee+bsdf"]
    if mode == "auto":
        return True, []
    if mode in MODES:
        return True, ["pilot=off", "mode=" + mode]
    raise ValueError("unknown mode %r (one of %s)" % (mode, ", ".join(MODES)))


# ---- running and reading ----------------------------------------------------------------------------

def run(cmd, **kw):
    """Runs a command; returns (wall seconds, stdout, stderr). Exits with the command's stderr on failure."""
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    seconds = time.monotonic() - t0
    if p.returncode != 0:
        sys.exit("bench: failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stderr.strip()[-3000:]))
    return seconds, p.stdout, p.stderr


def metadata(exr):
    _, out, _ = run(compare_cmd(exr, metadata=True))
    return dict(line.split(" ", 1) for line in out.splitlines() if " " in line)


def compare(test, ref, masks=()):
    """compare-images' figures of TEST against REF (relmse, relmse_trimmed, relmse_reference_noise, ...)."""
    _, out, _ = run(compare_cmd(test, ref, json_out=True, masks=masks))
    return json.loads(out)


def scene_fingerprint(scene):
    """The fingerprint render records for a scene (a 1-pixel, 1-sample render: the scene load only)."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "fp.exr")
        run(render_cmd(scene, out, spp=1, resolution="1x1", settings=["mode=nee+bsdf"]))
        return metadata(out).get("iris:scene_fingerprint", "?")


def split_stages(settings):
    """{stage: [name=value, ...]} for a flat list of preprocessing settings."""
    per = {"trace-photons": [], "place-caches": [], "fill-caches": []}
    for s in settings:
        name = s.split("=", 1)[0]
        if name not in STAGES:
            raise SystemExit("bench: %r is no preprocessing setting (one of %s)" % (name, ", ".join(sorted(STAGES))))
        for stage in STAGES[name]:
            per[stage].append(s)
    return per


def preprocess(scene, out, settings=(), resolution=None, seed=1, bin_dir=None):
    """The guided pipeline's preprocessing from scratch into OUT: (total seconds, {stage: seconds}), each the
    wall time of the tool's whole command (as pipelines/guided.mk times them). Writes OUT/atlas.h5.
    RESOLUTION: the image size place-caches places camera caches for; None: the film's own (what
    pipelines/guided.mk does without RESOLUTION, and what the ladders measured, also at half size)."""
    os.makedirs(out, exist_ok=True)
    per = split_stages(settings)
    photons, caches, atlas = (os.path.join(out, n) for n in ("photons.h5", "caches.h5", "atlas.h5"))
    parts = {}
    parts["photons"] = run(trace_photons_cmd(scene, photons, per["trace-photons"], seed, bin_dir=bin_dir))[0]
    parts["caches"] = run(place_caches_cmd(scene, photons, caches, resolution, per["place-caches"], seed,
                                           bin_dir=bin_dir))[0]
    parts["atlas"] = run(fill_caches_cmd(caches, photons, atlas, per["fill-caches"], seed, bin_dir=bin_dir))[0]
    return sum(parts.values()), parts


def atlas_summary(atlas):
    """(caches, map resolution, renderer's table bytes) from inspect-caches' summary."""
    _, out, _ = run(inspect_caches_cmd(atlas))
    return parse_inspect(out)


def parse_inspect(text):
    stats = dict(line.split(None, 1) for line in text.splitlines() if line.startswith(("caches ", "map ")))
    table = re.search(r"^render's table .*\((\d+) bytes\)", text, re.M)
    if "caches" not in stats:
        raise SystemExit("bench: inspect-caches printed no cache count")
    caches = int(stats["caches"].split()[0])
    res = int(stats["map"].split()[1]) if "map" in stats else 0
    return caches, res, int(table.group(1)) if table else 0
