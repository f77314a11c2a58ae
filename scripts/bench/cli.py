"""The harness's single entry point: `python3 -m scripts.bench <subcommand>` (see --help of each)."""
import argparse

from . import costs, filter_profile, peers, plots, published, selftest, spread, studies, tier

DOCS = "docs/benchmarks/"


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m scripts.bench", description=__doc__)
    sub = p.add_subparsers(dest="cmd", required=True, metavar="SUBCOMMAND")

    def add(name, func, help):
        s = sub.add_parser(name, help=help, description=help)
        s.set_defaults(func=func)
        return s

    tier.add_options(add("references", tier.cmd_references, "the references of a scene set (kept in --ref-dir)"))
    tier.add_options(add("ladder", tier.cmd_ladder, "references, equal-time ladder of modes per scene, report "
                         "(bench.mk quick, full, targets, glazed)"))
    s = add("report", tier.cmd_report, "re-write a ladder's report from its runs folder")
    s.add_argument("--runs-dir", required=True, help="out/bench/<report>")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--assets", required=True)
    s.add_argument("--tier", default="quick", help="prefix of the plot files")
    s.add_argument("--command", default="", help="the command line to quote")
    s = add("plots", plots.cmd_plots, "re-draw committed ladder reports' plots from their tables (no renders)")
    s.add_argument("reports", nargs="+")

    s = add("params", studies.cmd_params, "parameter studies: one preprocessing setting varied at a time")
    s.add_argument("--scene", default="scenes/thesis/cbox_kugeln.xml")
    s.add_argument("--name", default="cbox_kugeln")
    s.add_argument("--scale", type=float, default=0.5)
    s.add_argument("--budget", type=float, default=24, help="total seconds per render")
    s.add_argument("--ref-spp", type=int, default=8192)
    s.add_argument("--ref-dir", default=".cache/references")
    s.add_argument("--study", default="photon-paths=62500,125000,250000,500000;cache-count=1000,4000,16000;"
                   "gather-count=250,500,1000,2000;map-resolution=8,16,32;filter-sigma=0,0.75,1.5",
                   help="NAME=v1,v2,...;NAME2=... (preprocessing settings)")
    s.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE",
                   help="a preprocessing setting under every study (repeatable)")
    s.add_argument("--out", default="out/bench/params")
    s.add_argument("-o", "--output", default=DOCS + "params-cbox_kugeln.md")
    studies.add_common(add("hybrid", studies.cmd_hybrid, "hybrid caches (learn=on) against photon-only caches, "
                           "the door scene"), "out/bench/hybrid-door", DOCS + "hybrid-door.md", "240x160")
    studies.add_common(add("product", studies.cmd_product, "product sampling with glossy lobes against the map "
                           "alone"), "out/bench/product", DOCS + "product.md", "256x256")

    s = add("sampler", spread.cmd_sampler, "stratified (sobol) against independent pixel samples, equal spp")
    spread.add_options(s, "out/bench/sampler", DOCS + "sampler.md", 6)
    s.add_argument("--spp", type=int, default=64)
    s = add("ab", spread.cmd_ab, "two builds of render side by side, equal spp")
    spread.add_options(s, "out/bench/ab", DOCS + "ab.md", 6)
    s.add_argument("--old-bin", required=True, help="bin folder of build A (the baseline)")
    s.add_argument("--what", required=True, help="one line: what B changes")
    s.add_argument("--spp", type=int, default=64)
    for name, choice, seeds, help in (("guide-depth", "depth", 3, "guiding the first vertex against every vertex"),
                                      ("connect-choice", "connect", 4, "every vertex without and with connections")):
        s = add(name, spread.cmd_choice, help + ", equal time, spread across seeds")
        spread.add_options(s, "out/bench/" + name, DOCS + name + ".md", seeds)
        s.add_argument("--seconds", type=float, default=30)
        s.set_defaults(choice=choice)

    s = add("cost", costs.cmd_cost, "where the per-sample cost of guided rendering comes from, equal spp")
    s.add_argument("--spp", type=int, default=16)
    s.add_argument("--scale", type=float, default=0.5)
    s.add_argument("--repeats", type=int, default=5)
    s.add_argument("--resolution", default="", help="WxH instead of the scaled film")
    s.add_argument("--only", default="")
    s.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE")
    s.add_argument("--out", default="out/bench/cost")
    s.add_argument("-o", "--output", default=DOCS + "cost.md")
    s = add("resolution", costs.cmd_resolution, "map resolution against noise per sample, equal spp")
    s.add_argument("--spp", type=int, default=64)
    s.add_argument("--maps", default="16,32", help="map resolutions for every scene")
    s.add_argument("--no-extra", action="store_true", help="skip the extra resolutions some scenes get")
    s.add_argument("--resolution", default="", help="WxH instead of half the film (references then of --ref-spp)")
    s.add_argument("--ref-spp", type=int, default=2048)
    s.add_argument("--ref-dir", default=".cache/references")
    s.add_argument("--only", default="")
    s.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE")
    s.add_argument("--out", default="out/bench/resolution")
    s.add_argument("-o", "--output", default=DOCS + "resolution.md")
    s = add("throughput", costs.cmd_throughput, "render's rays per second against raw Embree (bench-rays)")
    s.add_argument("--spp", type=int, default=4)
    s.add_argument("--rays", type=int, default=4000000)
    s.add_argument("--resolution", default="")
    s.add_argument("--only", default="", help="comma-separated scene file names without .xml")
    s.add_argument("--out", default="out/bench/throughput")
    s.add_argument("-o", "--output", default=DOCS + "throughput.md")

    s = add("peers", peers.cmd_peers, "iris unguided, iris guided and Blender Cycles at equal total time")
    s.add_argument("--names", default="", help="of " + ", ".join(peers.SCENES))
    s.add_argument("--budgets", default="", help="for every scene instead of each one's")
    s.add_argument("--repeats", type=int, default=2)
    s.add_argument("--scale", type=float, default=0.5)
    s.add_argument("--ref-seconds", type=float, default=0, help="instead of each scene's")
    s.add_argument("--ref-dir", default=".cache/references")
    s.add_argument("--prep-set", action="append", default=[], metavar="NAME=VALUE")
    s.add_argument("--report", default="peers")
    s.add_argument("--docs", default="docs/benchmarks")
    s.add_argument("--runs", default="out/bench")
    published.add_options(add("published", published.cmd_published, "published Mitsuba scenes: iris against "
                              "Mitsuba's path integrator on the same files (means, relMSE, reference noise)"))
    filter_profile.add_options(add("filter-profile", filter_profile.cmd_filter_profile,
                                   "iris's and Cycles' pixel filter on a slanted emitter edge"))
    add("selftest", selftest.cmd_selftest, "the harness's own rules, checked without running a tool")
    a = p.parse_args(argv)
    a.func(a)
