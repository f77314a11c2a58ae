"""The equal-time ladder: configurations rendered at a ladder of total budgets (preprocessing counted
inside a guided budget), repeated with the configurations interleaved, each render compared with a
reference and the load recorded around it; per cell the median render (measure.median_render).
Every equal-time benchmark (the tiers, targets, hybrid, product, peers, params) runs through equal_time().
"""
import os

from . import measure, tools

SEED0 = 7  # repeat r renders with seed 7 + r


def iris_config(name, scene, resolution, reference, atlas=None, prep=0.0, settings=(), bin_dir=None, threads=None):
    """A configuration rendered by iris's render: NAME, PREP seconds of preprocessing counted in its budget."""
    def render(out, seconds, seed):
        cmd = tools.render_cmd(scene, out, atlas=atlas, seconds=seconds, resolution=resolution, seed=seed,
                               threads=threads, settings=settings, bin_dir=bin_dir)
        wall, _, _ = tools.run(cmd)
        return figures(out, reference, wall)
    return dict(name=name, prep=prep, render=render, settings=list(settings), atlas=atlas)


def figures(image, reference, wall):
    """One render's figures: its metadata and compare-images' against the reference."""
    meta = tools.metadata(image)
    c = tools.compare(image, reference)
    return dict(render_wall=wall, spp=int(meta.get("iris:spp", "0") or 0),
                sampling_seconds=float(meta.get("iris:seconds", "0") or 0), relmse=c["relmse"],
                relmse_trimmed=c["relmse_trimmed"], mape=c.get("mape"),
                relmse_reference_noise=c.get("relmse_reference_noise"), mean_test=c.get("mean_test"),
                mean_ref=c.get("mean_ref"), nonfinite=int(meta.get("iris:nonfinite_samples", "0") or 0),
                decision=meta.get("iris:auto_guide", ""))


def image_name(out_dir, name, budget, repeat, repeats):
    safe = name.replace("+", "_").replace(" ", "_").replace("/", "_")
    return os.path.join(out_dir, "%s-%gs%s.exr" % (safe, budget, "" if repeats == 1 else "-r%d" % (repeat + 1)))


def equal_time(configs, budgets, repeats, out_dir, log=print):
    """Renders every (configuration, budget) REPEATS times: repeats outermost, then budgets, then the
    configurations in measure.interleaved order. Returns {(name, budget): [render dicts]}; a configuration
    whose preprocessing alone exceeds a budget gets one {'skipped': why} entry there."""
    if repeats < 1:
        raise SystemExit("bench: repeats must be >= 1, got %d" % repeats)
    os.makedirs(out_dir, exist_ok=True)
    cells = {}
    for r in range(repeats):
        for b in budgets:
            for c in measure.interleaved(configs, r):
                seconds = measure.render_seconds(b, c["prep"])
                if seconds is None:
                    cells[(c["name"], b)] = [dict(name=c["name"], budget=b, prep=c["prep"],
                                                  skipped="preprocessing %.1f s exceeds the budget" % c["prep"])]
                    continue
                out = image_name(out_dir, c["name"], b, r, repeats)
                load_start = measure.load_now()
                x = c["render"](out, seconds, SEED0 + r)
                x.update(name=c["name"], budget=b, prep=c["prep"], total=x["render_wall"] + c["prep"], repeat=r,
                         seed=SEED0 + r, image=out, load_start=load_start, load_end=measure.load_now())
                cells.setdefault((c["name"], b), []).append(x)
                log("  %-18s %6.1f s r%d: relMSE %.4g (%s spp), total %.1f s, load %.1f%s"
                    % (c["name"], b, r + 1, x["relmse"], x.get("spp"), x["total"], load_start["load"][0],
                       ("  [" + x["decision"].split(":")[0] + "]") if x.get("decision") else ""))
    return cells


def cell_rows(cells, names, budgets):
    """Per budget and configuration the kept render (the median rule), with every repeat's relMSE x total."""
    rows = []
    for b in budgets:
        for n in names:
            xs = cells.get((n, b), [])
            if not xs:
                continue
            if "skipped" in xs[0]:
                rows.append(dict(xs[0]))
                continue
            x = dict(measure.median_render(xs))
            x["all_relmse"] = [y["relmse"] for y in xs]
            x["repeats"] = [round(y["relmse"] * y["total"], 6) for y in sorted(xs, key=lambda y: y["repeat"])]
            x["loads"] = [dict(start=y["load_start"], end=y["load_end"]) for y in xs]
            rows.append(x)
    return rows


def settings_table(rows, base_name):
    """The table of an equal-time comparison of configurations at one budget (hybrid, product): relMSE of
    the kept render and of every repeat, spp, total seconds, efficiency and its ratio to BASE_NAME's, also
    with the reference's own noise removed."""
    base = next((x for x in rows if x["name"] == base_name and "skipped" not in x), None)
    out = []
    for x in rows:
        if "skipped" in x:
            out.append([x["name"], "`%s`" % x.get("flags", ""), x["skipped"], "", "", "", "", ""])
            continue
        clean = measure.efficiency_ratio(x, base, clean=True) if base else None
        out.append([x["name"], "`%s`" % x.get("flags", ""),
                    "%.4g (%s)" % (x["relmse"], " / ".join("%.4g" % v for v in x["all_relmse"])), x["spp"],
                    "%.1f" % x["total"], "%.3g" % measure.efficiency(x),
                    "**%.2f**" % measure.efficiency_ratio(x, base) if base else "n/a",
                    "%.2f" % clean if clean is not None else "n/a"])
    return measure.md_table(["setting", "flags", "relMSE (kept; all)", "spp", "total s", "efficiency",
                             "vs %s" % base_name, "same, ref. noise removed"], out)
