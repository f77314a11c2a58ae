# The benchmarks: every target calls the one harness, `python3 -m scripts.bench <subcommand>` (scripts/bench/;
# `python3 -m scripts.bench --help` lists them, `... <subcommand> --help` their options). The harness owns the
# references (kept outside git in REF_DIR with a manifest; rendered again only when the scene's content, the
# size or the kind changed), the equal-time ladders (preprocessing counted inside a guided budget), the
# repeats (modes interleaved, the median render by relMSE x time kept), the load records (/proc/loadavg and
# nproc at each render's start and end), the Markdown reports in docs/benchmarks/ and the matplotlib plots.
#
#   make -f pipelines/bench.mk quick        # half resolution, budgets 6/12/24 s, 3 modes (~15 min + references)
#   make -f pipelines/bench.mk full         # full resolution, budgets 15..120 s, all modes (~2 h + references)
#   make -f pipelines/bench.mk full MODES=nee+bsdf,auto   # the two modes the targets compare (~50 min)
#   make -f pipelines/bench.mk quick ONLY='ring bidir' REPORT=quick-some   # some scenes, a report of their own
#   make -f pipelines/bench.mk references TIER=quick   # only the references
#   make -f pipelines/bench.mk targets      # issue 25's equal-time targets, guided references (~55 min + references)
#   make -f pipelines/bench.mk glazed       # the room lit through a glazed window (~20 min with its reference)
#   make -f pipelines/bench.mk params       # parameter studies on one scene (~10 min)
#   make -f pipelines/bench.mk hybrid       # hybrid vs photon-only caches on the door scene (~25 min)
#   make -f pipelines/bench.mk product      # product sampling with glossy lobes vs the map alone (~25 min)
#   make -f pipelines/bench.mk sampler      # stratified vs independent pixel samples (~12 min)
#   make -f pipelines/bench.mk guide-depth  # guiding the first vertex vs every vertex at equal time (~12 min)
#   make -f pipelines/bench.mk connect-choice  # every vertex without vs with caustic connections (~20 min)
#   make -f pipelines/bench.mk ab OLD_BIN=/tmp/old/build/bin WHAT='...' AB_REPORT=x  # two builds of render (~10 min)
#   make -f pipelines/bench.mk cost         # where guided rendering's per-sample cost comes from (~10 min)
#   make -f pipelines/bench.mk resolution   # map resolution against noise per sample (~15 min + references)
#   make -f pipelines/bench.mk throughput   # render's rays/s against raw Embree (~3 min)
#   make -f pipelines/bench.mk peers        # iris against Blender Cycles (~45 min); peers-glass (~20 min)
#   make -f pipelines/bench.mk plots        # re-draw the committed ladder reports' plots (no renders)
#   make -f pipelines/bench.mk published PUB_SCENES=<folder> MITSUBA=<dist>  # iris vs Mitsuba `path` on
#                                           published scene files (docs/PUBLISHED.md; ~40 min + references)
#   make -f pipelines/bench.mk selftest     # the harness's own rules, no tool run (seconds)
#   make -f pipelines/bench.mk smoke        # every subcommand but peers at 24x24-32x32 and 1-3 s (~5 min; out/bench/smoke)
#
# The runs are timed: run them on an otherwise idle machine, one at a time (no -j).

SHELL := /bin/bash
BIN ?= build/bin
# Debian's Python, which has python3-numpy and python3-matplotlib (a python3 earlier on PATH may not).
PYTHON ?= /usr/bin/python3
REF_DIR ?= .cache/references
BENCH = IRIS_BIN=$(BIN) BLENDER=$(BLENDER) $(PYTHON) -m scripts.bench
BLENDER ?= blender

# The ladder (quick, full, references, report): TIER sets scale, budgets and modes; each may be overridden.
# ONLY='name ...' restricts the seed scenes; REPORT names the report (docs/benchmarks/$(REPORT).md) and its
# runs folder (out/bench/$(REPORT)); REPEATS renders per cell; REF_SPP the unguided references' spp (the
# glass spheres get 4x by default); REF_GUIDED=SECONDS guided references instead (REF_CONNECT=auto: with
# caustic connections weighed by their pilot); PREP_SET='name=value ...' preprocessing settings.
TIER ?= quick
REPORT ?= $(TIER)
REPEATS ?= 1
REF_CONNECT ?= off
opt = $(if $(strip $(2)),$(1) '$(strip $(2))')
LADDER_OPTS = --tier $(TIER) --report $(REPORT) --repeats $(REPEATS) --ref-dir $(REF_DIR) --ref-connect $(REF_CONNECT) \
  $(call opt,--scale,$(SCALE)) $(call opt,--budgets,$(BUDGETS)) $(call opt,--modes,$(MODES)) \
  $(call opt,--only,$(ONLY)) $(call opt,--ref-spp,$(REF_SPP)) $(call opt,--ref-guided,$(REF_GUIDED)) \
  $(call opt,--scenes,$(SCENES)) $(foreach s,$(PREP_SET),--prep-set $(s))

.PHONY: quick full ladder references report targets glazed params hybrid product sampler guide-depth \
  connect-choice ab cost resolution throughput peers peers-glass peer-blender filter-profile plots selftest smoke \
  published

quick:
	@$(MAKE) -f pipelines/bench.mk TIER=quick ladder
full:
	@$(MAKE) -f pipelines/bench.mk TIER=full ladder
ladder:
	$(BENCH) ladder $(LADDER_OPTS)
references:
	$(BENCH) references $(LADDER_OPTS)
# Re-writes a ladder's report from its runs folder (no renders beyond the crops' comparisons).
report:
	$(BENCH) report --runs-dir out/bench/$(REPORT) -o docs/benchmarks/$(REPORT).md --assets docs/benchmarks/$(REPORT) \
	  --tier $(TIER)

# Issue 25's equal-time targets at half size: the four caustic seed scenes against guided references of
# 300 s (without caustic connections, so that they do not share the renders' technique), budgets 30/60 s,
# 2 repeats; the two scenes without caustics against unguided references of 1024 spp, budgets 15/30 s,
# 3 repeats; the two modes the targets compare. Reports targets-connect.md and targets-plain.md.
targets:
	@$(MAKE) -f pipelines/bench.mk TIER=quick REF_GUIDED=300 BUDGETS=30,60 MODES=nee+bsdf,auto REPEATS=2 \
	  ONLY='cbox_kugeln cbox_spiegelboxen bidir ring' REPORT=targets-connect ladder
	@$(MAKE) -f pipelines/bench.mk TIER=quick REF_SPP=1024 BUDGETS=15,30 MODES=nee+bsdf,auto REPEATS=3 \
	  ONLY='cbox_nur_box mi' REPORT=targets-plain ladder
# The room lit through a glazed window (a thin pane that shadow rays do not pass: the sky's light a caustic
# everywhere in the room) at its own 320 x 240, 30/60 s, 2 repeats, against a guided reference of 600 s with
# connections: glazed-room.md. ROOM=window_room: the room with the open window (window-room-connect.md).
ROOM ?= window_room_glazed
glazed:
	@$(MAKE) -f pipelines/bench.mk TIER=full SCENES='$(ROOM):scenes/window_room/$(ROOM).xml' SCALE=1 \
	  REF_GUIDED=600 REF_CONNECT=auto BUDGETS=30,60 MODES=nee+bsdf,auto REPEATS=2 \
	  REPORT=$(if $(filter window_room_glazed,$(ROOM)),glazed-room,$(subst _,-,$(ROOM))-connect) ladder

# Parameter studies (the thesis's: photon paths, cache count, photons per cache, map resolution, filter),
# one preprocessing setting at a time, at half size and PARAM_BUDGET seconds. PARAM_SCENE is a seed scene.
PARAM_SCENE ?= cbox_kugeln
PARAM_BUDGET ?= 24
PARAM_PATH = $(or $(word 2,$(subst :, ,$(filter $(PARAM_SCENE):%,cbox_kugeln:scenes/thesis/cbox_kugeln.xml \
  bidir:scenes/thesis/veach_bidir/bidir.xml cbox_spiegelboxen:scenes/thesis/cbox_spiegelboxen.xml \
  ring:scenes/thesis/metal_ring/ring.xml mi:scenes/thesis/veach_mi/mi.xml cbox_nur_box:scenes/thesis/cbox_nur_box.xml))),$(error unknown PARAM_SCENE $(PARAM_SCENE)))
params:
	$(BENCH) params --scene $(PARAM_PATH) --name $(PARAM_SCENE) --budget $(PARAM_BUDGET) --ref-dir $(REF_DIR) \
	  $(if $(filter cbox_kugeln,$(PARAM_SCENE)),,--ref-spp 2048) $(call opt,--study,$(PARAM_STUDY)) \
	  --out out/bench/params/$(PARAM_SCENE) -o docs/benchmarks/params-$(PARAM_SCENE).md

# Issue 25, part 1: hybrid caches (learn=on) against photon-only caches on the room lit through a door, with
# scarce (25k paths) and 250k photon paths: hybrid-door.md. Part 2: product sampling with glossy lobes against
# the map alone on the glossy spheres box: product.md. Each against a guided reference checked against an
# unguided one.
hybrid:
	$(BENCH) hybrid --ref-dir $(REF_DIR)
product:
	$(BENCH) product --ref-dir $(REF_DIR)

# Noise from the spread across seeds: the pixel sampler (sobol vs independent, 64 spp, 6 seeds): sampler.md;
# the pilot's choices at equal time (30 s): guide-depth.md (what render's shallow margin rests on) and
# connect-choice.md (the connections' margin).
sampler:
	$(BENCH) sampler
guide-depth:
	$(BENCH) guide-depth
connect-choice:
	$(BENCH) connect-choice
# Two builds of render side by side (a change that keeps the image and alters noise or cost): OLD_BIN is the
# baseline's bin folder (a worktree of an earlier commit built the same way, with this round's command
# line), WHAT says what changed. 64 spp, 6 seeds. Report docs/benchmarks/$(AB_REPORT).md.
AB_REPORT ?= ab
ab:
	@test -n "$(OLD_BIN)" || { echo "bench.mk: ab needs OLD_BIN=<bin folder of the baseline build>" >&2; exit 2; }
	$(BENCH) ab --old-bin $(OLD_BIN) --what "$(WHAT)" -o docs/benchmarks/$(AB_REPORT).md

# At equal spp, the render's own seconds and counters: the per-sample cost of guiding split into longer
# paths and the guiding itself (cost.md); map resolution against noise per sample (resolution.md, against
# the quick tier's references); render's rays/s against bench-rays' raw Embree rate (throughput.md).
cost:
	$(BENCH) cost
resolution:
	$(BENCH) resolution --ref-dir $(REF_DIR)
throughput:
	$(BENCH) throughput

# A peer (issue 25): iris unguided, iris guided (the tools' defaults) and Blender Cycles (Debian's package,
# scripts/cycles_render.py, its Gaussian filter matched to iris's) at equal total wall-clock budgets,
# PEER_REPEATS repeats, against time-bounded iris unguided references: peers.md (the glass box at 30/60/120 s,
# the plain box at 15/30/60 s, the mirror boxes at 30 s). peers-glass: the glass box alone at 30/60 s.
# Blender is a benchmark-only dependency (~300 MB): installed here when missing and run as root, never by
# scripts/install-deps.sh, and no test needs it.
PEER_REPEATS ?= 2
peer-blender:
	@command -v $(BLENDER) >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y blender; } || \
	  { echo "bench.mk: error: $(BLENDER) not found; install Debian's package: apt-get install blender" >&2; exit 1; }
peers: peer-blender
	$(BENCH) peers --repeats $(PEER_REPEATS) --ref-dir $(REF_DIR) $(call opt,--names,$(PEER_NAMES)) \
	  $(call opt,--budgets,$(PEER_BUDGETS)) $(call opt,--report,$(PEER_REPORT))
peers-glass: peer-blender
	$(BENCH) peers --names glass_box --budgets 30,60 --repeats $(PEER_REPEATS) --ref-dir $(REF_DIR) --report peers-glass
filter-profile: peer-blender
	$(BENCH) filter-profile --cycles-width 6

# The published-scene check (docs/PUBLISHED.md): every scene of PUB_NAMES under PUB_SCENES (a folder holding the
# fetched repositories' scenes, *.available.xml beside the originals) rendered by iris (default settings, each
# of PUB_BUDGETS seconds) and by Mitsuba's `path` (MITSUBA = dist folder of scripts/peers/build-mitsuba.sh;
# references cached under PUB_CACHE/<build id>/, default .cache/published), PUB_WIDTH pixels wide.
PUB_NAMES ?= cbox,kitchen,spaceship,torus,kitchenette,living_room,bathroom,clocks,cbox_with_bulb,glass_of_water,jewelry
PUB_WIDTH ?= 128
PUB_BUDGETS ?= 10,40
PUB_REF_SECONDS ?= 150
PUB_CACHE ?= .cache/published
published:
	@test -n "$(PUB_SCENES)" -a -n "$(MITSUBA)" || { echo "bench.mk: error: published needs PUB_SCENES=<folder of \
	  published scenes> MITSUBA=<dist folder of scripts/peers/build-mitsuba.sh>" >&2; exit 2; }
	$(BENCH) published --scenes $(PUB_SCENES) --mitsuba $(MITSUBA) --names $(PUB_NAMES) --width $(PUB_WIDTH) \
	  --budgets $(PUB_BUDGETS) --ref-seconds $(PUB_REF_SECONDS) --cache $(PUB_CACHE)

# Re-draws the committed ladder reports' plots from their tables (no renders; the budget on the time axis).
plots:
	$(BENCH) plots $(wildcard docs/benchmarks/full*.md docs/benchmarks/quick*.md)
selftest:
	$(BENCH) selftest

# Every subcommand but peers (Blender) once with tiny images, budgets and preprocessing, against BIN's tools:
# checks that the harness and the tools' command line fit together. Reports, references and renders all
# go to out/bench/smoke (not docs/); the figures mean nothing.
SMOKE := out/bench/smoke
SMOKE_PREP := --prep-set photon-paths=2000 --prep-set cache-count=100 --prep-set gather-count=50
smoke:
	rm -rf $(SMOKE)
	$(BENCH) selftest
	$(BENCH) ladder --scenes box:scenes/thesis/cbox_nur_box.xml,spheres:scenes/thesis/cbox_kugeln.xml --scale 0.0625 \
	  --budgets 1.5,3 --modes nee+bsdf,auto,nee+bsdf+cache --repeats 2 --ref-spp 16 --ref-dir $(SMOKE)/refs \
	  --runs $(SMOKE)/runs --docs $(SMOKE)/docs --report ladder $(SMOKE_PREP)
	$(BENCH) ladder --scenes spheres:scenes/thesis/cbox_kugeln.xml --scale 0.0625 --budgets 3 --modes nee+bsdf,auto \
	  --ref-guided 1 --ref-spp 16 --ref-dir $(SMOKE)/refs --runs $(SMOKE)/runs --docs $(SMOKE)/docs --report guided-ref $(SMOKE_PREP)
	$(BENCH) report --runs-dir $(SMOKE)/runs/ladder -o $(SMOKE)/docs/report.md --assets $(SMOKE)/docs/report
	$(BENCH) hybrid --resolution 32x24 --plan 2:2 --ref-spp 16 --ref-seconds 1 --ref-dir $(SMOKE)/refs \
	  --out $(SMOKE)/hybrid -o $(SMOKE)/docs/hybrid.md --prep-set cache-count=100 --prep-set gather-count=50
	$(BENCH) product --resolution 32x32 --plan 2.5:1 --ref-spp 16 --ref-seconds 1 --ref-dir $(SMOKE)/refs \
	  --out $(SMOKE)/product -o $(SMOKE)/docs/product.md $(SMOKE_PREP)
	$(BENCH) params --scene scenes/thesis/cbox_nur_box.xml --name box --scale 0.0625 --budget 2 --ref-spp 16 \
	  --ref-dir $(SMOKE)/refs --study 'map-resolution=8,16' --out $(SMOKE)/params -o $(SMOKE)/docs/params.md \
	  --prep-set photon-paths=2000 --prep-set min-caustic-share=0
	$(BENCH) sampler --resolution 24x24 --seeds 2 --spp 4 --only cbox_kugeln --out $(SMOKE)/sampler -o $(SMOKE)/docs/sampler.md $(SMOKE_PREP)
	$(BENCH) ab --old-bin $(BIN) --what smoke --resolution 24x24 --seeds 2 --spp 4 --only cbox_kugeln \
	  --out $(SMOKE)/ab -o $(SMOKE)/docs/ab.md $(SMOKE_PREP)
	$(BENCH) guide-depth --resolution 24x24 --seeds 2 --seconds 1 --only cbox_kugeln --out $(SMOKE)/gd -o $(SMOKE)/docs/gd.md $(SMOKE_PREP)
	$(BENCH) connect-choice --resolution 24x24 --seeds 2 --seconds 1 --only bidir --out $(SMOKE)/cc -o $(SMOKE)/docs/cc.md $(SMOKE_PREP)
	$(BENCH) cost --resolution 24x24 --spp 2 --repeats 2 --only cbox_kugeln --out $(SMOKE)/cost -o $(SMOKE)/docs/cost.md $(SMOKE_PREP)
	$(BENCH) resolution --resolution 24x24 --spp 2 --maps 4 --no-extra --only ring --ref-spp 16 --ref-dir $(SMOKE)/refs \
	  --out $(SMOKE)/res -o $(SMOKE)/docs/resolution.md $(SMOKE_PREP)
	$(BENCH) throughput --resolution 24x24 --spp 1 --rays 10000 --only cbox_nur_box --out $(SMOKE)/tp -o $(SMOKE)/docs/throughput.md
	@echo "bench.mk: smoke: every subcommand ran; reports in $(SMOKE)/docs"
