"""Benchmarks that measure noise from the spread across seeds (measure.seed_spread) rather than against a
reference: `sampler` (stratified against independent pixel samples, equal spp), `ab` (two builds of
render, equal spp), `guide-depth` and `connect-choice` (the pilot's choices, equal time). Per scene one
atlas (the tools' defaults) where a setting is guided; seeds outermost and settings interleaved inside
each seed, so that a busy spell of the machine hits all of them."""
import os
import shlex
import sys

from . import measure, tools
from .. import exr

# The guided settings are what the pilot chose on these scenes in docs/benchmarks/targets-connect.md, fixed
# (pilot=off) so that every seed renders the same estimator.
GUIDED = ["pilot=off", "mode=nee+bsdf+cache"]
EVERY_VERTEX = ["guide-vertices=0", "rr-threshold=0.1"]
FIRST_VERTEX = ["guide-vertices=1", "rr-threshold=0.3"]
GUIDED_EVERY = GUIDED + EVERY_VERTEX + ["caustics=on", "connect=on"]

SAMPLER_SCENES = [
    ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270",
     [("nee+bsdf", []), ("guided", GUIDED + ["caustics=on", "light-paths=0.8"])]),
    ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256",
     [("nee+bsdf", []), ("guided", GUIDED_EVERY + ["light-paths=0.15"])]),
    ("cbox_nur_box", "scenes/thesis/cbox_nur_box.xml", "256x256", [("nee+bsdf", [])]),
]
AB_SCENES = [
    ("cbox_nur_box", "scenes/thesis/cbox_nur_box.xml", "256x256", [("nee+bsdf", [])]),
    ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256",
     [("nee+bsdf", []), ("guided", GUIDED_EVERY + ["light-paths=0.15"])]),
    ("bidir", "scenes/thesis/veach_bidir/bidir.xml", "384x288",
     [("nee+bsdf", []), ("guided", GUIDED_EVERY + ["light-paths=0.15"])]),
    ("door", "scenes/door/door.xml", "240x160", [("nee+bsdf", [])]),
    ("panel_box", "scenes/cbox/panel_box.xml", "256x256", [("nee+bsdf", [])]),
]
# Per choice: its two settings (label, settings), and per scene its resolution and the settings both share
# (the light paths per pixel and, for depth, the connections the pilot chose there).
CHOICES = {
    "depth": dict(
        title="Guiding the first vertex against every vertex",
        settings=[("first vertex", FIRST_VERTEX), ("every vertex", EVERY_VERTEX)],
        scenes=[("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", ["light-paths=0.133", "connect=on"]),
                ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270", ["light-paths=0.84", "connect=on"]),
                ("window_room", "scenes/window_room/window_room.xml", "320x240", ["light-paths=0.12"])]),
    "connect": dict(
        title="Guiding every vertex without and with caustic connections",
        settings=[("without connections", EVERY_VERTEX + ["connect=off"]),
                  ("with connections", EVERY_VERTEX + ["connect=on"])],
        scenes=[("bidir", "scenes/thesis/veach_bidir/bidir.xml", "384x288", ["light-paths=0.13"]),
                ("cbox_spiegelboxen", "scenes/thesis/cbox_spiegelboxen.xml", "256x256", ["light-paths=0.5"]),
                ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", ["light-paths=0.133"]),
                ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270", ["light-paths=0.84"])]),
}


def add_options(p, out, report, seeds):
    p.add_argument("--out", default=out, help="folder for the renders")
    p.add_argument("-o", "--output", default=report, help="report (Markdown)")
    p.add_argument("--seeds", type=int, default=seeds)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--only", default="", help="comma-separated scene names")
    p.add_argument("--resolution", default="", help="WxH for every scene instead of each one's (a smoke test)")
    p.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE",
                   help="a preprocessing setting for every atlas (repeatable); default: the tools' defaults")


def selected(scenes, a):
    only = set(filter(None, a.only.split(",")))
    chosen = [s for s in scenes if not only or s[0] in only]
    if not chosen:
        raise SystemExit("bench: no scene selected")
    for entry in chosen:
        out = os.path.join(a.out, entry[0])
        os.makedirs(out, exist_ok=True)
        res = a.resolution or entry[2]
        yield (entry[0], entry[1], res) + tuple(entry[3:]), out


def spread(jobs, seeds):
    """jobs: [(key, fn(seed) -> (wall seconds, image path))]; seeds outermost, jobs interleaved (reversed on
    every other seed). Returns measure.seed_spread's {key: (rel. variance, median seconds, efficiency)},
    the luminance images per key, and the load records."""
    images, seconds, loads = {}, {}, []
    for seed in range(1, seeds + 1):
        for key, fn in measure.interleaved(jobs, seed - 1):
            l0 = measure.load_now()
            wall, path = fn(seed)
            loads.append(dict(load_start=l0, load_end=measure.load_now()))
            seconds.setdefault(key, []).append(wall)
            images.setdefault(key, []).append(exr.rgb(path).mean(axis=2))
    return measure.seed_spread(images, seconds), images, loads


def render_job(scene, path, res, a, settings, atlas=None, spp=None, seconds=None, bin_dir=None, seed_offset=0):
    def fn(seed):
        cmd = tools.render_cmd(scene, path % seed, atlas=atlas, spp=spp, seconds=seconds, resolution=res,
                               seed=seed + seed_offset, threads=a.threads, settings=settings, bin_dir=bin_dir)
        return tools.run(cmd)[0], path % seed
    return fn


def atlas_for(scene, out, res, modes, prep_set):
    """The scene's atlas (the tools' defaults) where a mode is guided; camera caches placed for RES (None:
    for the film's own size)."""
    if any(m != "nee+bsdf" for m, _ in modes):
        tools.preprocess(scene, out, prep_set, res)
        return os.path.join(out, "atlas.h5")
    return None


def header(title, what):
    return ["## " + title, "", "`python3 -m scripts.bench %s`, %s, nproc %d. %s" % (
        shlex.join(sys.argv[1:]), measure.today(), measure.nproc(), what), ""]


NOISE = ("Relative variance: of one render, from the spread across the seeds of each pixel's luminance over "
         "(mean^2 + 0.01) (the mean: every render of the scene), averaged over the pixels. Seconds: median wall "
         "time of the render command. Efficiency = 1 / (relative variance x seconds).")


def cmd_sampler(a):
    if a.seeds < 2 or a.spp < 1:
        raise SystemExit("bench sampler: needs --seeds >= 2 and --spp >= 1")
    rows, loads = [], []
    for (name, scene, res, modes), out in selected(SAMPLER_SCENES, a):
        atlas = atlas_for(scene, out, None, modes, a.prep_set)
        jobs = []
        for mode, settings in modes:
            base = ["mode=nee+bsdf"] if mode == "nee+bsdf" else settings
            for sampler in ("independent", "sobol"):
                path = os.path.join(out, "%s-%s-%%d.exr" % (mode.replace("+", "_"), sampler))
                jobs.append(((mode, sampler), render_job(scene, path, res, a, base + ["sampler=" + sampler],
                                                         atlas=None if mode == "nee+bsdf" else atlas, spp=a.spp)))
        result, _, ld = spread(jobs, a.seeds)
        loads += ld
        for mode, _ in modes:
            ind, sob = result[(mode, "independent")], result[(mode, "sobol")]
            rows.append((name, mode, ind, sob))
            print("%s %s: relvar %.4g -> %.4g, efficiency x%.2f" % (name, mode, ind[0], sob[0], sob[2] / ind[2]), flush=True)
    lines = header("Pixel sampler: stratified (sobol) against independent",
                   "%d spp, %d seeds per cell. %s Load: %s." % (a.spp, a.seeds, NOISE, measure.load_summary(loads)))
    lines += measure.md_table(["scene", "mode", "independent: rel. variance", "seconds", "sobol: rel. variance",
                               "seconds", "efficiency sobol / independent"],
                              [["`%s`" % n, m, "%.4g" % i[0], "%.2f" % i[1], "%.4g" % s[0], "%.2f" % s[1],
                                "%.2f" % (s[2] / i[2])] for n, m, i, s in rows])
    pairs = [(u, g) for u, g in zip(rows, rows[1:]) if u[0] == g[0]]
    if pairs:
        lines += ["", "Efficiency of the guided mode over nee+bsdf, with each sampler:", ""]
        lines += measure.md_table(["scene", "independent", "sobol"],
                                  [["`%s`" % u[0], "%.2f" % (g[2][2] / u[2][2]), "%.2f" % (g[3][2] / u[3][2])]
                                   for u, g in pairs])
    measure.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


def cmd_ab(a):
    """Two builds of render (A: --old-bin, B: this checkout's) at equal spp; B's seeds differ from A's, so
    that the difference of their means tests that they estimate one image. Both must take this round's
    command line (tools.render_cmd)."""
    import numpy as np
    if a.seeds < 2 or a.spp < 1:
        raise SystemExit("bench ab: needs --seeds >= 2 and --spp >= 1")
    if not os.path.isfile(os.path.join(a.old_bin, "render")):
        raise SystemExit("bench ab: no render in --old-bin %s" % a.old_bin)
    rows, loads = [], []
    for (name, scene, res, modes), out in selected(AB_SCENES, a):
        atlas = atlas_for(scene, out, res, modes, a.prep_set)
        for mode, settings in modes:
            jobs = []
            for build, bin_dir, offset in (("A", a.old_bin, 0), ("B", tools.BIN, 1000)):
                path = os.path.join(out, "%s-%s-%%d.exr" % (mode.replace("+", "_"), build))
                jobs.append((build, render_job(scene, path, res, a, ["mode=nee+bsdf"] if mode == "nee+bsdf" else settings,
                                               atlas=None if mode == "nee+bsdf" else atlas, spp=a.spp, bin_dir=bin_dir,
                                               seed_offset=offset)))
            result, images, ld = spread(jobs, a.seeds)
            loads += ld
            ma, mb = (np.mean(images[b], axis=0) for b in ("A", "B"))
            denom = (ma + mb) ** 2 / 4 + 0.01
            diff = float(np.mean((ma - mb) ** 2 / denom))
            noise = float(np.mean((np.var(images["A"], axis=0, ddof=1) + np.var(images["B"], axis=0, ddof=1))
                                  / a.seeds / denom))
            rows.append((name, mode, result["A"], result["B"], diff / noise))
            print("%s %s: efficiency B / A %.2f, mean difference / noise %.2f"
                  % (name, mode, result["B"][2] / result["A"][2], diff / noise), flush=True)
    lines = header("A/B: %s" % a.what,
                   "%d spp, %d seeds per cell, builds interleaved. A = `%s`, B = this checkout. %s Last column: the "
                   "mean squared relative difference of the two builds' mean images over what their noise alone "
                   "gives (about 1 when they estimate the same image). Load: %s."
                   % (a.spp, a.seeds, a.old_bin, NOISE, measure.load_summary(loads)))
    lines += measure.md_table(["scene", "mode", "A: rel. variance", "seconds", "B: rel. variance", "seconds",
                               "efficiency B / A", "mean difference / noise"],
                              [["`%s`" % n, m, "%.4g" % ra[0], "%.2f" % ra[1], "%.4g" % rb[0], "%.2f" % rb[1],
                                "%.2f" % (rb[2] / ra[2]), "%.2f" % same] for n, m, ra, rb, same in rows])
    measure.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


def cmd_choice(a):
    if a.seeds < 2 or not a.seconds > 0:
        raise SystemExit("bench %s: needs --seeds >= 2 and --seconds > 0" % a.cmd)
    choice = CHOICES[a.choice]
    (label_a, set_a), (label_b, set_b) = choice["settings"]
    rows, loads = [], []
    for (name, scene, res, shared), out in selected(choice["scenes"], a):
        atlas = atlas_for(scene, out, res, [("guided", [])], a.prep_set)
        jobs = [(label, render_job(scene, os.path.join(out, "%s-%d-%%d.exr" % (a.choice, i)), res, a,
                                   GUIDED + ["caustics=on"] + shared + settings, atlas=atlas, seconds=a.seconds))
                for i, (label, settings) in enumerate(choice["settings"])]
        r, _, ld = spread(jobs, a.seeds)
        loads += ld
        ra, rb = r[label_a], r[label_b]
        rows.append((name, " ".join(shared), ra, rb))
        print("%s: efficiency %s / %s %.2f" % (name, label_b, label_a, rb[2] / ra[2]), flush=True)
    lines = header(choice["title"] + ", at equal time",
                   "`render --time %g` per render, %d seeds per cell, one atlas per scene (the tools' defaults), "
                   "`%s` and the settings in the table; %s: `%s`, %s: `%s`. %s Load: %s."
                   % (a.seconds, a.seeds, " ".join(tools.sets(GUIDED + ["caustics=on"])), label_a,
                      " ".join(tools.sets(set_a)), label_b, " ".join(tools.sets(set_b)), NOISE,
                      measure.load_summary(loads)))
    lines += measure.md_table(["scene", "shared settings", "%s: rel. variance" % label_a, "%s: rel. variance" % label_b,
                               "efficiency %s / %s" % (label_b, label_a)],
                              [["`%s`" % n, "`%s`" % s, "%.4g" % ra[0], "%.4g" % rb[0], "%.2f" % (rb[2] / ra[2])]
                               for n, s, ra, rb in rows])
    measure.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)
