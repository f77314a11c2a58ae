"""Log-log plots of relMSE against seconds (matplotlib, Debian's python3-matplotlib), and re-drawing a
committed report's plots from its tables."""
import os
import re
import sys

COLOURS = {"nee+bsdf": "#444444", "nee+bsdf+cache": "#1f77b4", "auto": "#d62728", "nee+cache": "#2ca02c",
           "bsdf+cache": "#9467bd"}


def plot(title, series, path, xlabel="total seconds (preprocessing included)", points=None):
    """One line per series (name -> [(seconds, relMSE)]), optional scattered points (name -> [...], every
    repeat): path + '.png' and path + '.svg' (path without extension). No timestamps in the files, so that
    re-plotting the same data changes nothing in git."""
    pts = [(x, y) for s in series.values() for x, y in s if x > 0 and y > 0]
    if not pts:
        return False
    import matplotlib
    matplotlib.use("Agg")  # files only, no display
    matplotlib.rcParams["svg.hashsalt"] = "iris"  # fixed SVG ids: the same data gives the same file
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
    for i, (name, s) in enumerate(series.items()):
        s = sorted((x, y) for x, y in s if x > 0 and y > 0)
        colour = COLOURS.get(name, "C%d" % i)
        if s:
            ax.plot([x for x, _ in s], [y for _, y in s], marker="o", linewidth=2, markersize=4, color=colour,
                    label=name)
        extra = [(x, y) for x, y in (points or {}).get(name, []) if x > 0 and y > 0]
        if extra:
            ax.plot([x for x, _ in extra], [y for _, y in extra], ".", color=colour, alpha=0.5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    xs = sorted({x for x, _ in pts})
    ax.set_xticks(xs if len(xs) <= 8 else [])
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1, 2, 5)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(xlabel)
    ax.set_ylabel("relMSE")
    ax.set_title(title)
    ax.grid(True, which="both", color="#dddddd", linewidth=0.6)
    ax.legend(loc="upper right", frameon=False)
    fig.tight_layout()
    fig.savefig(path + ".png", metadata={"Software": None})
    fig.savefig(path + ".svg", metadata={"Date": None, "Creator": None})
    plt.close(fig)
    return True


def read_report_tables(md):
    """The per-scene ladders of a committed report (written by `ladder`): {name: (title, {mode: [(budget
    seconds, relMSE), ...]})}. The report keeps the budgets, not each render's measured total seconds, so
    plots made from it put the budget on the time axis; the measured totals are within a few percent."""
    scenes, name, title, modes = {}, None, None, None
    for line in open(md):
        m = re.match(r"### `([^`]+)` \((\d+x\d+)", line)
        if m:
            name, title, modes = m.group(1), "%s (%s)" % (m.group(1), m.group(2)), None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if name and line.startswith("| budget (s) |"):
            modes = [c[:-len(" relMSE (spp)")] for c in cells[1:] if c.endswith(" relMSE (spp)")]
            scenes[name] = (title, {mm: [] for mm in modes})
            continue
        if name and modes and re.match(r"\| [0-9.]+ \|", line):
            budget = float(cells[0])
            vals = [c for c in cells[1:] if re.match(r"[0-9.e+-]+ \(\d+\)$", c)]
            for mm, v in zip(modes, vals):
                scenes[name][1][mm].append((budget, float(v.split()[0])))
        elif modes and not line.startswith("|"):
            modes = None if line.strip() else modes
    return scenes


def cmd_plots(a):
    """Re-draws the plots of committed reports from their tables (no renders)."""
    for md in a.reports:
        report = os.path.splitext(os.path.basename(md))[0]
        assets = os.path.join(os.path.dirname(md), report)
        scenes = read_report_tables(md)
        if not scenes:
            sys.exit("bench plots: error: %s: no per-scene relMSE tables found" % md)
        os.makedirs(assets, exist_ok=True)
        # The files' prefix is the tier the report was run at ("full-bidir.svg" in docs/benchmarks/full-ring/).
        prefix = "quick" if report.startswith("quick") else "full"
        for name, (title, series) in scenes.items():
            plot(title, series, os.path.join(assets, "%s-%s" % (prefix, name)), xlabel="total seconds (the budget)")
            print("%s: %s-%s.png, .svg" % (assets, prefix, name))
