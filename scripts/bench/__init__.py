"""iris's benchmark harness: one program for references, equal-time ladders, repeats, load records,
Markdown tables and matplotlib plots. Run it from the repository root with Debian's python3 (it has
python3-numpy and python3-matplotlib):

  /usr/bin/python3 -m scripts.bench <subcommand> [options]     (pipelines/bench.mk calls it)
  /usr/bin/python3 -m scripts.bench selftest                   (its own rules, no tool run)

Modules: tools (every tool command, one function per tool), measure (the shared rules), references,
ladder (the equal-time loop), tier, studies, spread, costs, peers, plots, filter_profile, selftest, cli.
"""
