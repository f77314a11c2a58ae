"""The tiered benchmark (issue 4): for every scene of a set, a reference, the preprocessing once, then
every mode at a ladder of total budgets against the reference (ladder.equal_time), results.json per scene
and one report, docs/benchmarks/<report>.md, with tables, plots and image crops. Subcommands `references`,
`ladder` and `report`."""
import glob
import json
import os
import shlex
import sys

from . import ladder, measure, plots, references, tools

# The seed scenes (name: path under scenes/thesis).
SEED_SCENES = [("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml"), ("bidir", "scenes/thesis/veach_bidir/bidir.xml"),
               ("cbox_spiegelboxen", "scenes/thesis/cbox_spiegelboxen.xml"), ("ring", "scenes/thesis/metal_ring/ring.xml"),
               ("mi", "scenes/thesis/veach_mi/mi.xml"), ("cbox_nur_box", "scenes/thesis/cbox_nur_box.xml")]
TIERS = {
    "quick": dict(scale=0.5, budgets="6,12,24", modes="nee+bsdf,auto,nee+bsdf+cache"),
    "full": dict(scale=1.0, budgets="15,30,60,120", modes="nee+bsdf,auto,nee+bsdf+cache,nee+cache,bsdf+cache"),
}
REF_SPP = 2048
# The glass spheres' reference at 2048 spp carried relMSE 0.0083 of its own at full size, 40 % of the
# default pipeline's error at 120 s: four times the samples quarter it.
REF_SPP_SCENE = {"cbox_kugeln": 4 * REF_SPP}


def add_options(p):
    p.add_argument("--tier", choices=sorted(TIERS), default="quick", help="defaults of scale, budgets and modes")
    p.add_argument("--scenes", default="", help="name:path,... instead of the seed scenes")
    p.add_argument("--only", default="", help="comma- or space-separated scene names of the set")
    p.add_argument("--scale", type=float, help="of the film size")
    p.add_argument("--budgets", help="comma-separated total seconds")
    p.add_argument("--modes", help="comma-separated: " + ", ".join(tools.MODES))
    p.add_argument("--repeats", type=int, default=1,
                   help="renders per cell, modes interleaved, the median render by relMSE x time kept")
    p.add_argument("--ref-spp", type=int, default=0, help="unguided references of this many spp (default 2048; "
                   "the glass spheres 4x)")
    p.add_argument("--ref-guided", type=float, default=0, help="instead: guided references of this many seconds")
    p.add_argument("--ref-connect", choices=("off", "auto"), default="off",
                   help="caustic connections in guided references (default off)")
    p.add_argument("--ref-dir", default=".cache/references")
    p.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE",
                   help="a preprocessing setting (repeatable); default: the tools' defaults")
    p.add_argument("--report", help="report name: docs/benchmarks/<report>.md, runs in out/bench/<report> "
                   "(default the tier)")
    p.add_argument("--docs", default="docs/benchmarks")
    p.add_argument("--runs", default="out/bench")


def settings_of(a):
    t = TIERS[a.tier]
    scale = a.scale if a.scale is not None else t["scale"]
    budgets = [float(b) for b in (a.budgets or t["budgets"]).split(",")]
    modes = (a.modes or t["modes"]).split(",")
    for m in modes:
        try:
            tools.mode_settings(m)  # an unknown mode fails before anything runs
        except ValueError as e:
            raise SystemExit("bench: " + str(e))
    if a.scenes:
        scenes = [tuple(s.split(":", 1)) for s in a.scenes.split(",")]
    else:
        scenes = list(SEED_SCENES)
    only = set(a.only.replace(",", " ").split())
    if only:
        unknown = only - {n for n, _ in scenes}
        if unknown:
            raise SystemExit("bench: --only names no scene of the set: %s" % ", ".join(sorted(unknown)))
        scenes = [(n, p) for n, p in scenes if n in only]
    return scale, budgets, modes, scenes


def reference_for(a, name, scene, scale, resolution):
    """(path, spec) of a scene's reference at this scale."""
    if a.ref_guided:
        path = os.path.join(a.ref_dir, "%s-s%g-guided-%gs%s.exr" % (name, scale, a.ref_guided,
                                                                     "-connect" if a.ref_connect == "auto" else ""))
        return path, references.guided_seconds(a.ref_guided, a.ref_connect)
    spp = a.ref_spp or REF_SPP_SCENE.get(name, REF_SPP)
    return os.path.join(a.ref_dir, "%s-s%g-%dspp.exr" % (name, scale, spp)), references.unguided_spp(spp)


def check_file(a, name, scale):
    """An unguided reference of the scene at this scale to check a guided one against (nothing rendered)."""
    spp = a.ref_spp or REF_SPP_SCENE.get(name, REF_SPP)
    found = [p for p in [os.path.join(a.ref_dir, "%s-s%g-%dspp.exr" % (name, scale, spp))] if os.path.exists(p)]
    found += sorted(glob.glob(os.path.join(a.ref_dir, "%s-s%g-unguided-*.exr" % (name, scale))))
    return found[0] if found else None


def cmd_references(a):
    scale, _, _, scenes = settings_of(a)
    for name, scene in scenes:
        res = measure.scaled_resolution(scene, scale)
        path, spec = reference_for(a, name, scene, scale, res)
        references.ensure(scene, path, res, spec)


def run_scene(a, name, scene, scale, budgets, modes, out):
    res = measure.scaled_resolution(scene, scale)
    ref, spec = reference_for(a, name, scene, scale, res)
    references.ensure(scene, ref, res, spec)
    print("runs %s: budgets %s s, modes %s, %d repeat(s)" % (name, ",".join("%g" % b for b in budgets),
                                                             ",".join(modes), a.repeats), flush=True)
    guided = [m for m in modes if tools.mode_settings(m)[0]]
    prep, parts, atlas, auto_caches = 0.0, {}, None, None
    fixed = dict(atlas=None, prep=0.0)
    if guided:
        prep, parts = tools.preprocess(scene, out, a.prep_set)
        atlas = os.path.join(out, "atlas.h5")
        fixed = dict(atlas=atlas, prep=prep)
        auto_caches = tools.atlas_summary(atlas)[0]
        # The fixed guided modes show what guiding does: where the pipeline placed no caches (no light
        # through specular chains, min-caustic-share) they get a preprocessing of their own with caches forced.
        if any(m != "auto" for m in guided) and auto_caches == 0:
            forced = os.path.join(out, "forced")
            p, _ = tools.preprocess(scene, forced, a.prep_set + ["min-caustic-share=0"])
            fixed = dict(atlas=os.path.join(forced, "atlas.h5"), prep=p)
    configs = []
    for m in modes:
        needs_atlas, settings = tools.mode_settings(m)
        src = dict(atlas=atlas, prep=prep) if m == "auto" else fixed if needs_atlas else dict(atlas=None, prep=0.0)
        configs.append(ladder.iris_config(m, scene, res, ref, atlas=src["atlas"], prep=src["prep"], settings=settings))
    cells = ladder.equal_time(configs, budgets, a.repeats, out)
    rows = ladder.cell_rows(cells, modes, budgets)
    for x in rows:
        x["mode"] = x["name"]
    ref_meta = tools.metadata(ref)
    other = check_file(a, name, scale) if a.ref_guided else None
    info = dict(scene=scene, name=name, resolution=res, reference=ref, reference_kind=spec["kind"],
                reference_check=references.check(ref, other) if other else None,
                reference_spp=ref_meta.get("iris:spp"), prep=prep, prep_parts=parts, prep_settings=a.prep_set,
                rows=rows, repeats=a.repeats, date=measure.today(), nproc=measure.nproc())
    if guided:
        caches, map_res, table = tools.atlas_summary(fixed["atlas"])
        info.update(auto_caches=auto_caches, caches=caches, map_resolution=map_res, table_bytes=table,
                    atlas_bytes=os.path.getsize(fixed["atlas"]))
    measure.write_text(os.path.join(out, "results.json"), json.dumps(info, indent=1))
    return info


def cmd_ladder(a):
    scale, budgets, modes, scenes = settings_of(a)
    report = a.report or a.tier
    runs = os.path.join(a.runs, report)
    for name, scene in scenes:
        run_scene(a, name, scene, scale, budgets, modes, os.path.join(runs, name))
    write_report(runs, os.path.join(a.docs, report + ".md"), os.path.join(a.docs, report), a.tier,
                 "python3 -m scripts.bench " + shlex.join(sys.argv[1:]))


def cmd_report(a):
    write_report(a.runs_dir, a.output, a.assets, a.tier, a.command or "python3 -m scripts.bench " + shlex.join(sys.argv[1:]))


def crop_of(r, by, bmax):
    """The ninth of the image (3 x 3 grid) where the unguided render at the largest budget errs most."""
    w, h = (int(v) for v in r["resolution"].split("x"))
    cw, ch = w // 3, h // 3
    best, crop = -1.0, "%d,%d,%d,%d" % (cw, ch, 2 * cw, 2 * ch)
    u_img = by.get(("nee+bsdf", bmax), {}).get("image")
    if u_img and os.path.exists(u_img) and cw > 0 and ch > 0:
        for gy in range(3):
            for gx in range(3):
                x0, y0, x1, y1 = gx * cw, gy * ch, gx * cw + cw, gy * ch + ch
                masks = ["0,0,%d,%d" % (w, y0), "0,%d,%d,%d" % (y1, w, h), "0,%d,%d,%d" % (y0, x0, y1),
                         "%d,%d,%d,%d" % (x1, y0, w, y1)]
                e = tools.compare(u_img, r["reference"], masks=masks)["relmse"]
                if e > best:
                    best, crop = e, "%d,%d,%d,%d" % (x0, y0, x1, y1)
    return crop


def scene_section(r, assets, rel_assets, prefix, summary):
    name = r["name"]
    rows = [x for x in r["rows"] if "skipped" not in x]
    modes = []
    for x in r["rows"]:
        if x["mode"] not in modes:
            modes.append(x["mode"])
    budgets = sorted({x["budget"] for x in r["rows"]})
    by = {(x["mode"], x["budget"]): x for x in rows}
    lines = ["### `%s` (%s, reference: %s, %s spp)" % (name, r["resolution"], r["reference_kind"], r["reference_spp"]), ""]
    c = r.get("reference_check")
    if c:
        lines += [references.check_paragraph(c, "The reference", "an independent unguided one", ""), ""]
    if r["prep"]:
        pp = r["prep_parts"]
        lines.append("Preprocessing %.2f s (photons %.2f, caches %.2f, atlas %.2f); %d caches of %dx%d texels: "
                     "atlas file %.1f MB, the renderer's table %.1f MB. Preprocessing settings: %s."
                     % (r["prep"], pp.get("photons", 0), pp.get("caches", 0), pp.get("atlas", 0), r["caches"],
                        r["map_resolution"], r["map_resolution"], r["atlas_bytes"] / 1e6, r["table_bytes"] / 1e6,
                        " ".join(r["prep_settings"]) or "the tools' defaults"))
        if r.get("auto_caches") == 0:
            lines[-1] += (" The default preprocessing placed no caches here (less than min-caustic-share of the "
                          "photon power arrives through specular chains): `auto` rendered unguided after it, and the "
                          "fixed guided modes used caches of a forced preprocessing (min-caustic-share=0).")
        lines.append("")
    lines.append("Load: %s." % measure.load_summary(rows))
    lines.append("")
    head = ["budget (s)"]
    for m in modes:
        head += ["%s relMSE (spp)" % m] if m == "nee+bsdf" else ["%s relMSE (spp)" % m, "eff. ratio", "ref. noise removed"]
    table = []
    for b in budgets:
        cells, u = ["%g" % b], by.get(("nee+bsdf", b))
        for m in modes:
            x = by.get((m, b))
            if not x:
                cells += ["n/a"] if m == "nee+bsdf" else ["n/a", "n/a", "n/a"]
                continue
            cells.append("%.4g (%d)" % (x["relmse"], x["spp"]))
            if m != "nee+bsdf":
                clean = measure.efficiency_ratio(x, u, clean=True) if u else None
                cells += ["%.2f" % measure.efficiency_ratio(x, u) if u else "n/a",
                          "%.2f" % clean if clean is not None else "n/a"]
        table.append(cells)
    lines += measure.md_table(head, table) + [""]
    bmax = budgets[-1]
    u = by.get(("nee+bsdf", bmax))
    for m in modes:
        x = by.get((m, bmax))
        if m == "nee+bsdf" or not x or not u:
            continue
        cost = (x["sampling_seconds"] / x["spp"]) / (u["sampling_seconds"] / u["spp"]) if x["spp"] and u["spp"] else 0
        trim = (u["relmse_trimmed"] * u["total"]) / (x["relmse_trimmed"] * x["total"])
        summary.append((name, m, bmax, measure.efficiency_ratio(x, u), trim,
                        measure.efficiency_ratio(x, u, clean=True), cost, x["prep"] / bmax, x.get("decision", "")))
        lines.append("- %s at %g s: per-sample cost %.2fx nee+bsdf (sampling seconds per spp, pilot included), "
                     "preprocessing %.1f %% of the budget%s" % (m, bmax, cost, 100 * x["prep"] / bmax,
                                                                 ("; " + x["decision"]) if x.get("decision") else ""))
    lines.append("")
    series = {m: [(x["total"], x["relmse"]) for (mm, _), x in by.items() if mm == m] for m in modes}
    stem = os.path.join(assets, "%s-%s" % (prefix, name))
    if plots.plot("%s (%s)" % (name, r["resolution"]), series, stem):
        lines += ["![relMSE against time, %s](%s)" % (name, os.path.join(rel_assets, os.path.basename(stem) + ".png")), ""]
    crop = crop_of(r, by, bmax)
    heads, cells = [], []
    for m in modes + ["reference"]:
        src = r["reference"] if m == "reference" else by.get((m, bmax), {}).get("image")
        if not src or not os.path.exists(src):
            continue
        png = os.path.join(assets, "%s-%s-%s.png" % (prefix, name, m.replace("+", "_")))
        tools.run(tools.compare_cmd(src, srgb_png=png, crop=crop))
        heads.append(m)
        cells.append("![%s](%s)" % (m, os.path.join(rel_assets, os.path.basename(png))))
    if heads:
        lines += ["Crops at %g s (pixels %s, the ninth of the image where nee+bsdf errs most):" % (bmax, crop), ""]
        lines += measure.md_table(heads, [cells]) + [""]
    return lines


def write_report(runs, output, assets, tier, command):
    results = []
    for d in sorted(os.listdir(runs)) if os.path.isdir(runs) else []:
        p = os.path.join(runs, d, "results.json")
        if os.path.exists(p):
            with open(p) as f:
                results.append(json.load(f))
    if not results:
        raise SystemExit("bench report: no results.json under %s" % runs)
    os.makedirs(assets, exist_ok=True)
    rel_assets = os.path.relpath(assets, os.path.dirname(output) or ".")
    repeats = results[0].get("repeats", 1)
    per_cell = ("one render per cell" if repeats == 1 else
                "per cell the median render of %d by relMSE x time (lower middle for an even count), seeds 7 on, "
                "modes interleaved" % repeats)
    prefix = "quick" if tier.startswith("quick") else "full"
    head = ["## Run time against error (%s)" % os.path.splitext(os.path.basename(output))[0], "",
            "`%s`, %s, nproc %s. Every render of a scene is compared with a reference of the same size (its own "
            "noise is part of every relMSE, so the plain ratios are conservative; the columns 'ref. noise removed' "
            "take it out using the reference's variance layers). Time is the wall time of the whole `render` "
            "command plus, for guided modes, the preprocessing (`trace-photons` + `place-caches` + `fill-caches`, "
            "each timed around its command); each guided render gets `--time` = budget - preprocessing. "
            "Efficiency = 1 / (relMSE x time); the ratio is taken against nee+bsdf at the same budget (> 1: the "
            "mode wins at equal time). `auto` is `render --atlas` with the tools' defaults (the pilot decides); "
            "the fixed guided modes are `--set pilot=off --set mode=<mode>`. Each cell: %s."
            % (command, results[0]["date"], results[0].get("nproc", "-"), per_cell), ""]
    summary, body = [], []
    for r in results:
        body += scene_section(r, assets, rel_assets, prefix, summary)
    top = ["### Summary at the largest budget", "",
           "Efficiency from relMSE, from relMSE with the worst 0.1 % of pixels dropped (on scenes with fireflies "
           "the plain figure swings by tens of percent between seeds, the trimmed one much less), and from relMSE "
           "less the reference's own share (its variance layers: mean of var_ref / (ref^2 + 0.01)). `auto` shows "
           "what its pilot chose.", ""]
    top += measure.md_table(["scene", "mode", "budget (s)", "efficiency vs nee+bsdf", "same, trimmed relMSE",
                             "same, reference noise removed", "per-sample cost", "preprocessing share", "auto chose"],
                            [["`%s`" % n, m, "%g" % b, "%.2f" % e, "%.2f" % t, "%.2f" % c if c is not None else "n/a",
                              "%.2fx" % cost, "%.1f %%" % (100 * s), d.split(":")[0] if d else ""]
                             for n, m, b, e, t, c, cost, s, d in summary]) + [""]
    measure.write_text(output, "\n".join(head + top + body).rstrip() + "\n")
    print("wrote %s" % output)
