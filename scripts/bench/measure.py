"""The measurement rules every benchmark shares (no tool is run here, so that selftest can check them):
film sizes, the equal-time budget, the interleaved order of repeats, the median rule, load records,
noise from the spread across seeds, efficiencies with the reference's own noise removed, manifests.

Efficiency = 1 / (relMSE x total wall seconds): ratios of it at the same budget are the headline figures.
"""
import os
import statistics
import sys
import time
import xml.etree.ElementTree as ET


def film_size(scene):
    """Width and height of the scene's film (Mitsuba's defaults 768 x 576), also where it is in a file the
    scene <include>s (paths relative to the including file, as the loader reads them)."""
    size = [768, 576]

    def visit(path):
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError) as e:
            sys.exit("bench: cannot read the film size from %s: %s" % (path, e))
        for e in root.iter():
            if e.tag == "include":
                visit(os.path.join(os.path.dirname(path), e.get("filename")))
            elif e.tag == "film":
                for i in e.findall("integer"):
                    if i.get("name") in ("width", "height"):
                        size[i.get("name") == "height"] = int(i.get("value"))

    visit(scene)
    return size[0], size[1]


def scaled_resolution(scene, scale):
    """'WxH' of the scene's film scaled by SCALE (at least 1 x 1)."""
    w, h = film_size(scene)
    return "%dx%d" % (max(1, round(w * scale)), max(1, round(h * scale)))


def write_text(path, text):
    """Writes a file whole or not at all (a temporary beside it, renamed): an interrupted benchmark never
    leaves a half-written report, results file or manifest."""
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path + ".tmp", "w") as f:
        f.write(text)
    os.replace(path + ".tmp", path)


def nproc():
    """The processors this process may run on (what `nproc` prints)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count()


def load_now(loadavg="/proc/loadavg"):
    """The machine's load: (1, 5, 15-minute averages from /proc/loadavg, nproc). The machine is shared, so
    every cell records it at its start and end."""
    with open(loadavg) as f:
        a = f.read().split()
    return dict(load=[float(a[0]), float(a[1]), float(a[2])], nproc=nproc())


def render_seconds(budget, prep):
    """Equal total time: a configuration with PREP seconds of preprocessing renders BUDGET - PREP seconds
    (so that preprocessing and rendering cost BUDGET together). None when nothing is left to render."""
    t = budget - prep
    return t if t > 0 else None


def interleaved(items, repeat):
    """The order of the configurations in repeat REPEAT (0-based): reversed on every other repeat, so that
    neither always runs second while the shared machine's speed drifts."""
    return list(items) if repeat % 2 == 0 else list(items)[::-1]


def median_render(renders):
    """The median rule for repeats: the render whose relMSE x total seconds is the median of the cell's
    (with an even count the lower of the middle two, so that the kept figures are one real render's)."""
    if not renders:
        raise ValueError("median_render of no renders")
    xs = sorted(renders, key=lambda x: x["relmse"] * x["total"])
    return xs[(len(xs) - 1) // 2]


def efficiency(x):
    return 1.0 / (x["relmse"] * x["total"])


def net_relmse(x):
    """relMSE less the reference's own share (compare-images' estimate from the reference's variance
    layers): on average the relMSE against the truth. None where the reference has no variance layers or
    its share exceeds the relMSE."""
    n = x.get("relmse_reference_noise")
    if n is None or x["relmse"] <= n:
        return None
    return x["relmse"] - n


def efficiency_ratio(x, base, clean=False):
    """Efficiency of render x over render base; clean: with the reference's own noise taken out of both."""
    if clean:
        nx, nb = net_relmse(x), net_relmse(base)
        if nx is None or nb is None:
            return None
        return (nb * base["total"]) / (nx * x["total"])
    return (base["relmse"] * base["total"]) / (x["relmse"] * x["total"])


def seed_spread(images, seconds):
    """Noise from the spread across seeds. images: key -> luminance images of one scene, one per seed (every
    key estimates the same image); seconds: key -> wall times. Per key (relative variance of one render,
    median seconds, efficiency = 1 / (relative variance x seconds)); the relative variance is the variance
    across the seeds of each pixel over (mean^2 + 0.01), the mean over every render of the scene, averaged
    over the pixels. A render's own sample variance cannot stand in for it: stratified samples are not
    independent."""
    import numpy as np
    mean = np.mean([im for ims in images.values() for im in ims], axis=0)
    denom = mean * mean + 0.01
    result = {}
    for key, ims in images.items():
        rv = float(np.mean(np.var(np.array(ims), axis=0, ddof=1) / denom))
        t = statistics.median(seconds[key])
        result[key] = (rv, t, 1.0 / (rv * t))
    return result


def read_manifest(path):
    """A reference's manifest: 'key value' lines -> dict ({} when missing)."""
    try:
        with open(path) as f:
            return dict(line.rstrip("\n").split(" ", 1) for line in f if " " in line)
    except OSError:
        return {}


def format_manifest(fields):
    return "".join("%s %s\n" % (k, v) for k, v in fields.items())


def today():
    return time.strftime("%Y-%m-%d", time.gmtime())


def md_table(head, rows):
    """A Markdown table: head and rows are lists of cells (str() of each)."""
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        if len(r) != len(head):
            raise ValueError("row of %d cells under a head of %d: %r" % (len(r), len(head), r))
        lines.append("| " + " | ".join(str(c) for c in r) + " |")
    return lines


def load_summary(renders):
    """'1-minute load at the cells' starts and ends: median m, range a-b; nproc n' for a list of renders."""
    loads = [v for x in renders for k in ("load_start", "load_end") if x.get(k) for v in [x[k]["load"][0]]]
    procs = sorted({x[k]["nproc"] for x in renders for k in ("load_start", "load_end") if x.get(k)})
    if not loads:
        return "load not recorded"
    return ("1-minute load at the renders' starts and ends median %.1f, range %.1f-%.1f; nproc %s"
            % (statistics.median(loads), min(loads), max(loads), "/".join(str(p) for p in procs)))
