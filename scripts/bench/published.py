"""The published-scene check (issue 47): each published Mitsuba scene file, rendered by iris as it is and by
Mitsuba's stock `path` integrator (a variant of the same file, mitsuba_xml.variant), compared at one small
size: per-channel means, relMSE of iris against Mitsuba at several iris budgets, and the Mitsuba
reference's own noise from two renders with different seeds.

Mitsuba references are cached (--cache, default .cache/published/<build id>/): one is rendered again only
when the scene file, its variant, the image size, the spp or the Mitsuba build (its core library, `path`
and sampler plugins) changed. iris renders go to --out and are always made afresh.

Figures, all over the whole image (non-finite pixels counted and left out):
  mean(c)         mean of channel c; Mitsuba's = that of the reference (the mean of its two seeds)
  SE              standard error of a channel mean, from the two seeds: sqrt(sum_p (a_p - b_p)^2 / 2) / n for
                  one render, / sqrt(2) for their mean (pixels are independent with the independent sampler)
  relMSE(x, r)    mean over pixels and channels of (x - r)^2 / (r^2 + 0.01)  (compare-images' definition)
  ref. share      the reference's own part of a relMSE against it: relMSE(a, b) / 4 (its noise is half each
                  seed's, and relMSE(a, b) holds both seeds' noise)
A 1 % check of a channel mean is decided only where 3 x the combined SE of the two means is below 1 %.
"""
import glob
import hashlib
import json
import math
import os
import re
import resource
import subprocess
import sys
import time

from . import measure, mitsuba_xml, tools

BEGIN, END = "<!-- published:begin (written by python3 -m scripts.bench published) -->", "<!-- published:end -->"


def add_options(s):
    s.add_argument("--scenes", required=True, help="folder of published scenes: every file ending in --suffix "
                   "under it but simple.* and *-improved.* (the same scenes with another integrator)")
    s.add_argument("--suffix", default=".available.xml", help="scene files' ending (default .available.xml: "
                   "copies whose shapes with absent files are commented out; .xml for complete checkouts)")
    s.add_argument("--mitsuba", required=True, help="dist folder of scripts/peers/build-mitsuba.sh (holds mitsuba)")
    s.add_argument("--names", default="", help="comma-separated scene names (the file's stem, or its folder "
                   "where the file is scene.available.xml); default every scene found")
    s.add_argument("--skip", default="glass_of_milk", help="names left out (default glass_of_milk: a medium)")
    s.add_argument("--width", type=int, default=128, help="image width; the height keeps the film's aspect")
    s.add_argument("--budgets", default="10,40", help="iris render budgets in seconds (two or more)")
    s.add_argument("--target-se", type=float, default=0.003, help="relative standard error of each channel mean "
                   "the report compares with the spp it would need (the references spend --ref-seconds)")
    s.add_argument("--ref-seconds", type=float, default=150, help="cap on one scene's two reference renders "
                   "in machine seconds (processor seconds / threads), from a pilot's cost per sample")
    s.add_argument("--min-spp", type=int, default=16)
    s.add_argument("--pilot-spp", type=int, default=4)
    s.add_argument("--threads", type=int, default=2)
    s.add_argument("--references-only", action="store_true", help="render (or find) the Mitsuba references only")
    s.add_argument("--cache", default=".cache/published")
    s.add_argument("--out", default="out/bench/published")
    s.add_argument("-o", "--output", default="docs/PUBLISHED.md", help="the Markdown file whose measured "
                   "section (between the published:begin/end markers) is rewritten")


def log(msg):
    print("published: " + msg, flush=True)


# ---- scenes ------------------------------------------------------------------------------------------

def scene_name(path, suffix=".available.xml"):
    stem = os.path.basename(path)[:-len(suffix)]
    return os.path.basename(os.path.dirname(path)) if stem == "scene" else stem


def find_scenes(folder, names, skip, suffix):
    found = {}
    for p in sorted(glob.glob(os.path.join(folder, "**", "*" + suffix), recursive=True)):
        base = os.path.basename(p)
        if base.startswith("simple.") or "-improved." in base or (suffix == ".xml" and ".available." in base):
            continue
        found.setdefault(scene_name(p, suffix), p)
    if names:
        missing = [n for n in names if n not in found]
        if missing:
            sys.exit("bench published: error: no *%s for %s under %s" % (suffix, ", ".join(missing), folder))
        found = {n: found[n] for n in names}
    return {n: p for n, p in found.items() if n not in skip}


def size_for(info, width):
    return width, max(1, round(width * info["height"] / info["width"]))


# ---- Mitsuba -----------------------------------------------------------------------------------------

def sha(path_or_bytes):
    h = hashlib.sha256()
    if isinstance(path_or_bytes, bytes):
        h.update(path_or_bytes)
    else:
        with open(path_or_bytes, "rb") as f:
            h.update(f.read())
    return h.hexdigest()


def build_id(dist):
    """Identity of a Mitsuba build: its core and render libraries, `path` and the independent sampler."""
    parts = ["libmitsuba-core.so", "libmitsuba-render.so", "plugins/path.so", "plugins/independent.so"]
    for p in ["mitsuba"] + parts:
        if not os.path.exists(os.path.join(dist, p)):
            sys.exit("bench published: error: %s: no %s (give the dist folder of scripts/peers/build-mitsuba.sh)"
                     % (dist, p))
    return hashlib.sha256("".join(sha(os.path.join(dist, p)) for p in parts).encode()).hexdigest()[:12]


def render_seconds(text):
    """Mitsuba's own 'Render time: 12.3s' / '1.5m' / '2h' line (the rendering, without the scene load)."""
    m = re.findall(r"Render time: ([0-9.]+)(ms|s|m|h|d)", text)
    if not m:
        return None
    v, unit = float(m[-1][0]), m[-1][1]
    return v * {"ms": 1e-3, "s": 1, "m": 60, "h": 3600, "d": 86400}[unit]


def mitsuba_render(dist, scene, text, spp, seed, size, out_dir, tag, threads):
    """One Mitsuba render of the variant of SCENE (cached). Returns its manifest (dict)."""
    var = mitsuba_xml.variant(text, spp, seed, *size)
    base = os.path.join(out_dir, "%s-%dx%d-%dspp-seed%d" % (tag, size[0], size[1], spp, seed))
    exr, man = base + ".exr", base + ".json"
    key = dict(scene=os.path.abspath(scene), scene_sha=sha(text.encode()), variant_sha=sha(var.encode()),
               spp=spp, seed=seed, width=size[0], height=size[1])
    if os.path.exists(exr) and os.path.exists(man):
        with open(man) as f:
            old = json.load(f)
        if all(old.get(k) == v for k, v in key.items()):
            return old
    os.makedirs(out_dir, exist_ok=True)
    measure.write_text(base + ".xml", var)
    # The variant lives in the cache; -a adds the scene's folder to Mitsuba's search path for its meshes.
    cmd = [os.path.join(dist, "mitsuba"), "-p", str(threads), "-a", os.path.dirname(os.path.abspath(scene)),
           "-o", os.path.abspath(exr), os.path.abspath(base + ".xml")]
    env = dict(os.environ, LD_LIBRARY_PATH=dist)
    load0 = measure.load_now()
    t0, ru0 = time.monotonic(), resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(["nice", "-n", "10"] + cmd, capture_output=True, text=True, env=env, cwd=out_dir)
    wall, ru1 = time.monotonic() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    # processor seconds of the whole process (load, render, write): what the render cost the shared machine
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    logtext = p.stdout + p.stderr
    if p.returncode != 0 or not os.path.exists(exr):
        errors = [l for l in logtext.splitlines() if re.search(r"\bERROR\b|Error|error", l)]
        raise RuntimeError("Mitsuba failed (%d): %s" % (p.returncode, (errors or logtext.splitlines()[-3:] or ["?"])[-1]))
    warnings = sorted({re.sub(r"^.*?WARN\s+\S+\s+", "", l).strip() for l in logtext.splitlines() if " WARN " in l})
    rec = dict(key, wall=wall, cpu=cpu, render_seconds=render_seconds(logtext), warnings=warnings, load_start=load0,
               load_end=measure.load_now(), command="LD_LIBRARY_PATH=%s nice -n 10 %s" % (dist, " ".join(cmd)))
    measure.write_text(man, json.dumps(rec, indent=1))
    return rec


def channel_stats(img):
    """(means[3], finite mask) over the finite pixels."""
    import numpy as np
    ok = np.all(np.isfinite(img), axis=2)
    return [float(img[..., c][ok].mean()) for c in range(3)], ok


def relmse(t, r):
    import numpy as np
    ok = np.all(np.isfinite(t), axis=2) & np.all(np.isfinite(r), axis=2)
    return float(np.mean(((t - r) ** 2 / (r * r + 0.01))[ok]))


def se_from_pair(a, b):
    """Standard error of one render's channel means, from two independent renders A and B."""
    import numpy as np
    ok = np.all(np.isfinite(a), axis=2) & np.all(np.isfinite(b), axis=2)
    n = ok.sum()
    return [float(math.sqrt(np.sum(((a[..., c] - b[..., c]) ** 2)[ok]) / 2) / n) for c in range(3)]


def rel_se_max(means, se):
    """The largest relative SE over the channels that carry light (mean above 0.1 % of the largest)."""
    top = max(means) if means else 0
    vals = [s / m for m, s in zip(means, se) if m > 1e-3 * top and m > 0]
    return max(vals) if vals else float("inf")


def reference(a, name, scene, text, size, dist, cache):
    """Two seeds of Mitsuba `path`, sized from a pilot pair: (reference image, record for the report)."""
    from .. import exr
    out = os.path.join(cache, name)
    log("%s: Mitsuba pilot, 2 x %d spp at %dx%d" % (name, a.pilot_spp, *size))
    pa = mitsuba_render(dist, scene, text, a.pilot_spp, 1, size, out, "pilot", a.threads)
    pb = mitsuba_render(dist, scene, text, a.pilot_spp, 2, size, out, "pilot", a.threads)
    ia = exr.rgb(os.path.join(out, "pilot-%dx%d-%dspp-seed1.exr" % (*size, a.pilot_spp)))
    ib = exr.rgb(os.path.join(out, "pilot-%dx%d-%dspp-seed2.exr" % (*size, a.pilot_spp)))
    means, _ = channel_stats((ia + ib) / 2)
    rse = rel_se_max(means, se_from_pair(ia, ib))  # one pilot render's
    # machine seconds (processor seconds over the threads: the wall time of an idle machine), split into the
    # scene load and the samples by the share of the process's wall time that Mitsuba reports as rendering
    def split(x):
        machine = x["cpu"] / a.threads
        frac = min(1.0, (x["render_seconds"] or x["wall"]) / max(x["wall"], 1e-6))
        return machine * (1 - frac), machine * frac / a.pilot_spp
    overhead, per_spp = min(split(x)[0] for x in (pa, pb)), max(1e-4, min(split(x)[1] for x in (pa, pb)))
    # the reference = mean of two renders of N spp: its relative SE = rse * sqrt(pilot / N) / sqrt(2)
    want = math.ceil(a.pilot_spp * (rse / (a.target_se * math.sqrt(2))) ** 2) if math.isfinite(rse) else a.min_spp
    cap = int(max(0.0, a.ref_seconds / 2 - overhead) / per_spp)
    # The whole --ref-seconds is spent: the channel means may reach the wanted SE much earlier, but every
    # pixel's noise is what floors the relMSE of iris against the reference (its share is reported).
    spp = max(a.min_spp, cap) if math.isfinite(rse) else a.min_spp  # a black pilot: nothing to measure
    log("%s: pilot %.3g s to load, %.3g s/spp, relative SE %.2g -> %d spp wanted, %d affordable: 2 x %d spp (~%.0f s each)"
        % (name, overhead, per_spp, rse, want, cap, spp, spp * per_spp))
    recs = [mitsuba_render(dist, scene, text, spp, seed, size, out, "ref", a.threads) for seed in (11, 12)]
    ra, rb = (exr.rgb(os.path.join(out, "ref-%dx%d-%dspp-seed%d.exr" % (*size, spp, s))) for s in (11, 12))
    ref = (ra + rb) / 2
    means, ok = channel_stats(ref)
    se1 = se_from_pair(ra, rb)
    rec = dict(spp=spp, wanted=want, means=means, se=[s / math.sqrt(2) for s in se1], se_single=se1,
               relmse_seeds=relmse(ra, rb), nonfinite=int((~ok).sum()),
               seconds=[x["render_seconds"] or x["wall"] for x in recs], cpu=[x["cpu"] for x in recs],
               warnings=recs[0]["warnings"],
               loads=[x["load_start"] for x in recs] + [x["load_end"] for x in recs],
               files=[os.path.join(out, "ref-%dx%d-%dspp-seed%d.exr" % (*size, spp, s)) for s in (11, 12)])
    log("%s: reference %d spp, means %s, relative SE %s, relMSE between seeds %.3g"
        % (name, spp, fmt3(means), fmt3([s / m if m else 0 for s, m in zip(rec["se"], means)], pct=True),
           rec["relmse_seeds"]))
    return ref, rec


# ---- iris --------------------------------------------------------------------------------------------

def iris_run(scene, out, size, seconds, seed, threads):
    """iris render with default settings; (ok, wall, stderr lines)."""
    cmd = [tools.BIN + "/render", scene, "-o", out, "--resolution", "%dx%d" % size, "-t", str(threads), "-q",
           "--seed", str(seed)] + (["--time", "%g" % seconds] if seconds else ["--spp", "1"])
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    return p.returncode == 0 and os.path.exists(out), time.monotonic() - t0, p.stderr.strip().splitlines(), cmd


def warnings_of(lines):
    return [l for l in lines if "warning" in l.lower()]


def iris_side(a, name, scene, size, budgets, ref, ref_rec):
    from .. import exr
    out = os.path.join(a.out, name)
    os.makedirs(out, exist_ok=True)
    ok, _, lines, _ = iris_run(scene, os.path.join(out, "load.exr"), size, None, 1, a.threads)
    rec = dict(loads=ok, warnings=warnings_of(lines), error=None if ok else (lines[-1] if lines else "?"), runs=[])
    if not ok:
        log("%s: iris does not load it: %s" % (name, rec["error"]))
        return rec
    for i, t in enumerate(budgets):
        path = os.path.join(out, "iris-%gs.exr" % t)
        log("%s: iris render %g s" % (name, t))
        load0 = measure.load_now()
        ok, wall, lines, cmd = iris_run(scene, path, size, t, 1 + i, a.threads)
        if not ok:
            rec["error"] = lines[-1] if lines else "?"
            log("%s: iris failed: %s" % (name, rec["error"]))
            return rec
        img = exr.rgb(path)
        means, okm = channel_stats(img)
        r = dict(budget=t, wall=wall, means=means, nonfinite=int((~okm).sum()), load_start=load0,
                 load_end=measure.load_now(), command=" ".join(cmd))
        if ref is not None:
            r["relmse"] = relmse(img, ref)
        rec["runs"].append(r)
        log("%s: iris %g s: means %s%s" % (name, t, fmt3(means),
                                           ", relMSE %.4g" % r["relmse"] if "relmse" in r else ""))
    return rec


# ---- report ------------------------------------------------------------------------------------------

def fmt3(v, pct=False):
    return "/".join(("%.2f%%" % (100 * x)) if pct else ("%.4g" % x) for x in v)


def verdict(iris_means, ref_rec):
    """Per channel: relative difference and whether the 1 % check can be decided (3 SE < 1 %)."""
    cells = []
    for c in range(3):
        m = ref_rec["means"][c]
        if m <= 0:
            cells.append("-")
            continue
        d = iris_means[c] / m - 1
        se = ref_rec["se"][c] / m
        cells.append("%+.2f%%%s" % (100 * d, "" if 3 * se < 0.01 else " (ref. noise)"))
    return cells


def write_report(a, results, budgets, dist, bid, started):
    head = ["scene", "size", "Mitsuba spp (wanted), machine s", "Mitsuba R/G/B", "ref. SE R/G/B", "relMSE seeds",
            "iris R/G/B (%gs)" % budgets[-1], "diff R", "diff G", "diff B"] + \
           ["relMSE %gs" % t for t in budgets] + ["ref. share", "relMSE x s"]
    rows, notes = [], []
    for name, r in results.items():
        ref, iris = r.get("ref"), r.get("iris")
        size = "%dx%d" % r["size"]
        if iris is not None:
            w = iris["warnings"]
            notes.append("- **%s**: iris %s; %s" % (
                name, "loads" if iris["loads"] else "does not load: `%s`" % iris["error"],
                ("%d warning(s):\n" % len(w) + "\n".join("  - `%s`" % x for x in w)) if w else "no warnings"))
        else:
            notes.append("- **%s**: iris not run" % name)
        if ref is None:
            rows.append([name, size, "Mitsuba failed"] + [""] * (len(head) - 3))
            notes.append("  - Mitsuba failed: `%s`" % r.get("ref_error"))
            continue
        cells = [name, size, "2 x %d (%d), %.0f s" % (ref["spp"], ref["wanted"], sum(ref["cpu"]) / a.threads),
                 fmt3(ref["means"]),
                 fmt3([s / m if m else 0 for s, m in zip(ref["se"], ref["means"])], pct=True),
                 "%.3g" % ref["relmse_seeds"]]
        share = ref["relmse_seeds"] / 4
        if iris is None or not iris["runs"]:
            why = "not run" if iris is None else "does not load"
            cells += [why] + [""] * (len(head) - len(cells) - 1)
            rows.append(cells)
        else:
            last = iris["runs"][-1]
            cells += [fmt3(last["means"])] + verdict(last["means"], ref)
            cells += ["%.4g" % x["relmse"] for x in iris["runs"]]
            cells += ["%.2g" % share, "/".join("%.3g" % ((x["relmse"] - share) * x["wall"]) for x in iris["runs"])]
            rows.append(cells)
        if ref["warnings"]:
            notes.append("  - Mitsuba warned: " + "; ".join("`%s`" % x for x in ref["warnings"][:6]))
    loads = [x for r in results.values() for x in ((r.get("iris") or {}).get("runs") or [])]
    refloads = [v["load"][0] for r in results.values() if r.get("ref") for v in r["ref"]["loads"]]
    when = time.strftime("%Y-%m-%d %H:%M", time.gmtime(started))
    load = "iris renders: " + measure.load_summary(loads)
    if refloads:
        load += "; Mitsuba references (cached ones from when they were made): 1-minute load %.1f-%.1f" % (
            min(refloads), max(refloads))
    lines = [BEGIN, "", "Measured %s UTC with %d threads each. Mitsuba build `%s` (`%s`); iris `%s`. Load: %s." % (
        when, a.threads, bid, dist, tools.BIN, load), "",
        "Command: `python3 -m scripts.bench %s`" % " ".join(sys.argv[1:]), ""]
    lines += measure.md_table(head, rows)
    lines += ["", "Mitsuba spp: two seeds of that many spp (the spp a 0.3 %% standard error wanted), machine s = their "
              "processor seconds / %d threads. " % a.threads + "diff = iris mean / Mitsuba mean - 1 at the longest budget; \"(ref. noise)\": 3 x the reference's "
              "standard error of that channel mean exceeds 1 %, so the 1 % check is not decided there (iris's own "
              "standard error, one render per budget, is not in it). "
              "relMSE x s = (relMSE - ref. share) x iris's wall seconds per budget: constant where iris's "
              "own noise is all that separates it from Mitsuba, rising where a bias remains.", "",
              "Warnings and load errors per scene:", ""] + notes + ["", END]
    block = "\n".join(lines) + "\n"
    # the report names the scenes' folder by its option, not by this machine's path
    # and the Mitsuba build and the reference cache by theirs (longest path first: one may hold another)
    names = [(a.scenes, "<scenes>"), (a.mitsuba, "<mitsuba>"), (a.cache, "<cache>")]
    paths = [(f, name) for p, name in names for f in {os.path.abspath(p), p.rstrip("/")}]
    for folder, name in sorted(paths, key=lambda x: len(x[0]), reverse=True):
        block = block.replace(folder + "/", name + "/").replace(folder, name)
    old = open(a.output).read() if os.path.exists(a.output) else "# Published scenes\n\n" + BEGIN + "\n" + END + "\n"
    if BEGIN not in old or END not in old:
        old = old.rstrip("\n") + "\n\n" + BEGIN + "\n" + END + "\n"
    new = old[:old.index(BEGIN)] + block + old[old.index(END) + len(END) + 1:]
    measure.write_text(a.output, new)
    measure.write_text(os.path.join(a.out, "results.json"), json.dumps(results, indent=1, default=str))
    log("report written to %s (raw figures in %s)" % (a.output, os.path.join(a.out, "results.json")))


def cmd_published(a):
    started = time.time()
    names = [n for n in a.names.split(",") if n]
    skip = {n for n in a.skip.split(",") if n}
    budgets = [float(x) for x in a.budgets.split(",") if x]
    if len(budgets) < 2 and not a.references_only:
        sys.exit("bench published: error: --budgets needs two or more budgets (relMSE must fall with time)")
    dist = os.path.abspath(a.mitsuba)
    bid = build_id(dist)
    cache = os.path.join(a.cache, bid)
    if not a.references_only and not os.path.exists(tools.BIN + "/render"):
        sys.exit("bench published: error: %s/render not found (build iris, or set IRIS_BIN)" % tools.BIN)
    scenes = find_scenes(a.scenes, names, skip, a.suffix)
    log("%d scenes: %s; Mitsuba build %s, references cached in %s" % (len(scenes), ", ".join(scenes), bid, cache))
    results = {}
    for name, scene in scenes.items():
        text = open(scene, encoding="utf-8").read()
        try:
            info = mitsuba_xml.inspect(text)
        except mitsuba_xml.SceneError as e:
            sys.exit("bench published: error: %s: %s" % (scene, e))
        size = size_for(info, a.width)
        r = results[name] = dict(scene=scene, size=size, ref=None, iris=None)
        try:
            ref_img, r["ref"] = reference(a, name, scene, text, size, dist, cache)
        except (RuntimeError, mitsuba_xml.SceneError) as e:
            r["ref_error"] = str(e)
            log("%s: %s" % (name, e))
            ref_img = None
        if not a.references_only:
            r["iris"] = iris_side(a, name, scene, size, budgets, ref_img, r["ref"])
        write_report(a, results, budgets, dist, bid, started)  # after every scene: an interrupted run still reports
    log("done: %d scenes, references in %s" % (len(results), cache))
