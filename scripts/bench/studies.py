"""Equal-time studies of render and preprocessing settings on one scene: `hybrid` (issue 25, part 1:
hybrid caches against photon-only caches on the room lit through a door), `product` (part 2: product
sampling with glossy lobes against the map alone) and `params` (the thesis's parameter studies, one
preprocessing setting varied at a time). Each through ladder.equal_time, against a reference checked
against an independent one where it is guided."""
import os
import shlex
import sys

from . import ladder, measure, references, tools

EVERY = ["pilot=off", "mode=nee+bsdf+cache", "guide-vertices=0", "rr-threshold=0.1"]
FIRST = ["pilot=off", "mode=nee+bsdf+cache", "guide-vertices=1"]


def command_line():
    return "python3 -m scripts.bench " + shlex.join(sys.argv[1:])


def add_common(p, out, report, resolution):
    p.add_argument("--out", default=out, help="folder for the renders and atlases")
    p.add_argument("-o", "--output", default=report, help="report (Markdown)")
    p.add_argument("--ref-dir", default=".cache/references")
    p.add_argument("--resolution", default=resolution)
    p.add_argument("--plan", default="", help="budget:repeats,... instead of the study's (e.g. 2:1 for a smoke test)")
    p.add_argument("--ref-spp", type=int, default=2048, help="spp of the unguided reference")
    p.add_argument("--ref-seconds", type=float, default=0, help="seconds of the guided reference (default the study's)")
    p.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE",
                   help="a preprocessing setting for every atlas (repeatable); default: the tools' defaults")


def plan_of(a, default):
    if not a.plan:
        return default
    return [(float(b), int(r)) for b, r in (p.split(":") for p in a.plan.split(","))]


def study(a, scene, configs_of, sections, ref_guided, ref_how, unguided_how):
    """The common body of hybrid and product: two references checked against each other, then per section
    (title, budget, repeats, config key) an equal-time table. configs_of(key, reference) -> configs."""
    res = a.resolution
    name = os.path.splitext(os.path.basename(scene))[0]
    ref_u = references.ensure(scene, os.path.join(a.ref_dir, "%s-%s-unguided-%dspp.exr" % (name, res, a.ref_spp)), res,
                              references.unguided_spp(a.ref_spp))
    ref_g = references.ensure(scene, os.path.join(a.ref_dir, "%s-%s-%s.exr" % (name, res, ref_guided["slug"])), res,
                              ref_guided["spec"])
    check = references.check(ref_g, ref_u)
    body, all_rows = [], []
    for title, budget, repeats, key in sections:
        configs = configs_of(key, ref_g)
        print("%s: %g s, %d repeat(s)" % (title, budget, repeats), flush=True)
        cells = ladder.equal_time(configs, [budget], repeats, os.path.join(a.out, "%s-%gs" % (key, budget)))
        rows = ladder.cell_rows(cells, [c["name"] for c in configs], [budget])
        for x in rows:
            x["flags"] = " ".join(tools.sets(next(c["settings"] for c in configs if c["name"] == x["name"])))
        all_rows += [x for x in rows if "skipped" not in x]
        body += ["## %s, %g s total (%d repeat%s)" % (title, budget, repeats, "s" if repeats > 1 else ""), ""]
        body += ladder.settings_table(rows, configs[0]["name"]) + [""]
    head = [references.check_paragraph(check, ref_how, unguided_how, "The tables use the first."), "",
            "Load: %s." % measure.load_summary(all_rows), ""]
    return head + body


def cmd_hybrid(a):
    scene = "scenes/door/door.xml"
    res = a.resolution
    # Two atlases: 25k photon paths (photons reach the near room badly) and 250k. min-caustic-share=0: the
    # door has no specular surface, so the default preprocessing would place no caches at all.
    plan = plan_of(a, [(30, 3), (60, 2), (30, 3)])
    keys = [25000, 25000, 250000][:len(plan)]
    preps = {}
    for paths in sorted(set(keys)):
        preps[paths] = tools.preprocess(scene, os.path.join(a.out, "p%d" % paths),
                                        a.prep_set + ["photon-paths=%d" % paths, "min-caustic-share=0"], res)[0]

    def configs_of(paths, ref):
        atlas = os.path.join(a.out, "p%d" % paths, "atlas.h5")
        return [ladder.iris_config("unguided", scene, res, ref, settings=["mode=nee+bsdf"]),
                ladder.iris_config("photons", scene, res, ref, atlas, preps[paths], EVERY),
                ladder.iris_config("hybrid", scene, res, ref, atlas, preps[paths], EVERY + ["learn=on"])]
    seconds = a.ref_seconds or 300
    ref_guided = dict(slug="hybrid-%gs" % seconds, spec=references.guided_seconds(
        seconds, prep=a.prep_set + ["photon-paths=25000", "min-caustic-share=0"], render=EVERY + ["learn=on"],
        label="hybrid %gs (25k photon paths, every vertex, learn=on)" % seconds, caches_at_size=True))
    sections = [("%dk photon paths" % (k // 1000), b, r, k) for (b, r), k in zip(plan, keys)]
    body = study(a, scene, configs_of, sections, ref_guided, "Hybrid, %g s" % seconds, "unguided, %d spp" % a.ref_spp)
    lines = ["# Hybrid caches on the room lit through a door (issue 25, part 1)", "",
             "`%s`, %s, nproc %d. `%s` at %s; every vertex guided (`%s`), photon-only caches against the same atlas "
             "with `learn=on` (hybrid) and the unguided tracer, interleaved, seeds 7 on, per setting the median "
             "render by relMSE x total seconds; guided totals include the preprocessing (min-caustic-share=0: "
             "%s). Efficiency = 1 / (relMSE x total seconds)."
             % (command_line(), measure.today(), measure.nproc(), scene, res, " ".join(tools.sets(EVERY)),
                ", ".join("%.2f s with %dk photon paths" % (preps[k], k // 1000) for k in sorted(preps))), ""] + body
    measure.write_text(a.output, "\n".join(lines).rstrip() + "\n")
    print("wrote " + a.output)


def cmd_product(a):
    scene = "scenes/cbox/glossy_spheres.xml"
    res = a.resolution
    prep = tools.preprocess(scene, a.out, a.prep_set, res)[0]
    atlas = os.path.join(a.out, "atlas.h5")

    def configs_of(_, ref):
        return [ladder.iris_config("unguided", scene, res, ref, settings=["mode=nee+bsdf"]),
                ladder.iris_config("every", scene, res, ref, atlas, prep, EVERY + ["product=off"]),
                ladder.iris_config("every+product", scene, res, ref, atlas, prep, EVERY + ["product=on"]),
                ladder.iris_config("first", scene, res, ref, atlas, prep, FIRST + ["product=off"]),
                ladder.iris_config("first+product", scene, res, ref, atlas, prep, FIRST + ["product=on"])]
    seconds = a.ref_seconds or 240
    ref_guided = dict(slug="every-%gs" % seconds, spec=references.guided_seconds(
        seconds, prep=a.prep_set, render=EVERY + ["product=off"], label="guided %gs (every vertex, the map alone)" % seconds,
        caches_at_size=True))
    sections = [("Equal time", b, r, "t") for b, r in plan_of(a, [(30, 3), (60, 2)])]
    body = study(a, scene, configs_of, sections, ref_guided, "Guided (every vertex, the map alone), %g s" % seconds,
                 "unguided, %d spp" % a.ref_spp)
    lines = ["# Product sampling with glossy lobes (issue 25, part 2)", "",
             "`%s`, %s, nproc %d. `%s` at %s (the glass-spheres box with a rough aluminium floor, GGX alpha 0.3, and "
             "a rough copper back wall, alpha 0.2). The map alone against its product with the lobe (`product=on`), "
             "guiding every vertex and the first vertex, beside the unguided tracer; interleaved, seeds 7 on, per "
             "setting the median render by relMSE x total seconds; guided totals include the preprocessing (the "
             "tools' defaults: %.2f s). Efficiency = 1 / (relMSE x total seconds)."
             % (command_line(), measure.today(), measure.nproc(), scene, res, prep), ""] + body
    measure.write_text(a.output, "\n".join(lines).rstrip() + "\n")
    print("wrote " + a.output)


def cmd_params(a):
    """One preprocessing setting varied at a time from the defaults, fixed guiding (pilot=off, the first
    vertex, so that the pilot's choice does not hide the setting's effect) against nee+bsdf at one budget."""
    res = measure.scaled_resolution(a.scene, a.scale)
    studies = []
    for part in a.study.split(";"):
        var, _, values = part.partition("=")
        tools.split_stages(["%s=0" % var.strip()])  # an unknown setting fails before anything runs
        studies.append((var.strip(), [v.strip() for v in values.split(",") if v.strip()]))
    ref = references.ensure(a.scene, os.path.join(a.ref_dir, "%s-s%g-%dspp.exr" % (a.name, a.scale, a.ref_spp)), res,
                            references.unguided_spp(a.ref_spp))
    lines = ["## Parameter studies: `%s` at %g s (%s)" % (a.name, a.budget, res), "",
             "`%s`, %s, nproc %d. One preprocessing setting is varied at a time, the others at the tools' defaults; "
             "each guided render (`%s`) gets `--time` = %g s - its preprocessing and is compared with the unguided "
             "reference (%s). Efficiency = 1 / (relMSE x total time), as a ratio to a nee+bsdf render of the same "
             "budget made just before each table's renders (the shared machine's speed drifts over minutes). "
             "relMSE x spp (per-sample error) separates the quality of the guiding from its cost. One render per "
             "cell, seed 7." % (command_line(), measure.today(), measure.nproc(), " ".join(tools.sets(FIRST)),
                                a.budget, ref), ""]
    for var, values in studies:
        out = os.path.join(a.out, var)
        base_cfg = ladder.iris_config("nee+bsdf", a.scene, res, ref, settings=["mode=nee+bsdf"])
        base = ladder.cell_rows(ladder.equal_time([base_cfg], [a.budget], 1, out), ["nee+bsdf"], [a.budget])[0]
        print("  %s: nee+bsdf %.0f s: relMSE %.4g (%d spp)" % (var, a.budget, base["relmse"], base["spp"]))
        rows = []
        for v in values:
            prep_dir = os.path.join(out, "%s-%s" % (var, v))
            prep, _ = tools.preprocess(a.scene, prep_dir, a.prep_set + ["%s=%s" % (var, v)])
            atlas = os.path.join(prep_dir, "atlas.h5")
            cfg = ladder.iris_config("%s=%s" % (var, v), a.scene, res, ref, atlas, prep, FIRST)
            x = ladder.cell_rows(ladder.equal_time([cfg], [a.budget], 1, prep_dir), [cfg["name"]], [a.budget])[0]
            if "skipped" in x:
                rows.append([v, "%.2f" % prep, "", "", x["skipped"], "", "", "", ""])
                continue
            trim = base["relmse_trimmed"] * base["total"] / (x["relmse_trimmed"] * x["total"])
            rows.append([v, "%.2f" % prep, "%.1f" % (os.path.getsize(atlas) / 1e6), x["spp"], "%.4g" % x["relmse"],
                         "%.3g" % (x["relmse"] * x["spp"]), "%.4g" % x["relmse_trimmed"],
                         "%.2f" % measure.efficiency_ratio(x, base), "%.2f" % trim])
            print("  %s=%s: prep %.2f s, relMSE %.4g (%d spp)" % (var, v, prep, x["relmse"], x["spp"]))
        lines += ["### %s" % var, "", "nee+bsdf: relMSE %.4g at %d spp (relMSE x spp %.3g); load %s." % (
            base["relmse"], base["spp"], base["relmse"] * base["spp"], measure.load_summary([base])), ""]
        lines += measure.md_table([var, "preprocessing (s)", "atlas (MB)", "spp", "relMSE", "relMSE x spp",
                                   "trimmed relMSE", "efficiency vs nee+bsdf", "same, trimmed"], rows) + [""]
    measure.write_text(a.output, "\n".join(lines).rstrip() + "\n")
    print("wrote " + a.output)
