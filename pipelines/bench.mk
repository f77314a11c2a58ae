# Run time against error for the seed scenes (issue 4): references, ladders of equal-time renders per
# mode, and the report (docs/benchmarks/<tier>.md with SVG plots and image crops).
#
#   make -f pipelines/bench.mk quick        # half resolution, budgets 6/12/24 s, 3 modes (~15 min + references)
#   make -f pipelines/bench.mk full         # full resolution, budgets 15..120 s, all modes (~2 h + references)
#   make -f pipelines/bench.mk full MODES=nee+bsdf,auto   # the two modes the targets compare (~50 min)
#   make -f pipelines/bench.mk references TIER=quick   # only the references
#   make -f pipelines/bench.mk params PARAM_SCENE=cbox_kugeln   # parameter studies on one scene (~10 min)
#   make -f pipelines/bench.mk targets      # issue 25's equal-time targets, guided references (~55 min + references)
#   make -f pipelines/bench.mk quick MODES=nee+bsdf,auto ONLY='ring bidir' REPORT=quick-some   # some scenes
#   make -f pipelines/bench.mk hybrid       # hybrid vs photon-only caches on the door scene (~25 min)
#   make -f pipelines/bench.mk product      # product sampling with glossy lobes vs the map alone (~25 min)
#   make -f pipelines/bench.mk sampler      # stratified vs independent pixel samples (~12 min)
#   make -f pipelines/bench.mk guide-depth  # guiding the first vertex vs every vertex at equal time (~12 min)
#   make -f pipelines/bench.mk connect-choice  # guiding every vertex without vs with caustic connections (~20 min)
#   make -f pipelines/bench.mk ab OLD_BIN=/tmp/old/build/bin WHAT='...' AB_REPORT=x  # two builds of render (~10 min)
#
# References are unguided long renders (the path tracer alone, independent of the guiding code), kept
# outside git in $(REF_DIR) with a manifest (scene, fingerprint, resolution, spp, seconds, command); make
# rebuilds one only when its scene file changes. REF_SPP samples each, REF_SPP_<name> where a scene's
# reference needs more (its own noise is part of every relMSE measured against it). The per-scene runs
# always re-run (they are the measurement); run them on an otherwise idle machine, one at a time (no
# -j): they are timed.

SHELL := /bin/bash
.DELETE_ON_ERROR:

BIN ?= build/bin
# Debian's Python, which has python3-matplotlib for the plots (a python3 earlier on PATH may not).
PYTHON ?= /usr/bin/python3
SEEDS ?= scenes/thesis
REF_DIR ?= .cache/references
TIER ?= quick

# name:scene-path pairs
SCENES_ALL := cbox_kugeln:cbox_kugeln.xml bidir:veach_bidir/bidir.xml cbox_spiegelboxen:cbox_spiegelboxen.xml \
  ring:metal_ring/ring.xml mi:veach_mi/mi.xml cbox_nur_box:cbox_nur_box.xml

ifeq ($(TIER),full)
SCALE ?= 1
BUDGETS ?= 15,30,60,120
MODES ?= nee+bsdf,auto,nee+bsdf+cache,nee+cache,bsdf+cache
REF_SPP ?= 2048
else
SCALE ?= 0.5
BUDGETS ?= 6,12,24
MODES ?= nee+bsdf,auto,nee+bsdf+cache
REF_SPP ?= 2048
endif
# The glass spheres' reference at REF_SPP carried relMSE 0.0083 of its own at full size, 40 % of the
# default pipeline's error at 120 s (both relMSEs include it, which pulls their ratio towards 1): four
# times the samples quarter it (~30 min of both cores on the 2-core machine at full size, once).
REF_SPP_cbox_kugeln ?= $(shell echo $$((4 * $(REF_SPP))))
# Renders per cell (modes interleaved, seeds 7 on; the median by relMSE x time is kept): more than 1
# measures through the shared machine's +-10 % drift in sample rate, at REPEATS times the tier's time.
REPEATS ?= 1
# Settings passed to pipelines/guided.mk for the preprocessing (empty: its defaults).
PIPELINE ?=

# ONLY='name ...' restricts a tier to some scenes (their names above); REPORT names its runs folder and
# report (docs/benchmarks/$(REPORT).md; default the tier's), so that a subset does not replace the tier's.
ONLY ?=
REPORT ?= $(TIER)
ifneq ($(strip $(ONLY)),)
SCENES_ALL := $(filter $(addsuffix :%,$(ONLY)),$(SCENES_ALL))
endif
RUNS := out/bench/$(REPORT)
name_of = $(word 1,$(subst :, ,$(1)))
path_of = $(SEEDS)/$(word 2,$(subst :, ,$(1)))
# A scene's reference spp: REF_SPP_<name> where set (a scene whose reference needs more), else REF_SPP.
ref_spp = $(or $(REF_SPP_$(1)),$(REF_SPP))
# REF_GUIDED=SECONDS: guided references instead (the default pipeline with an atlas of its own seeds,
# SECONDS of rendering each): on the caustic scenes an unguided reference's own noise is a large part of a
# guided render's relMSE even at 2048 spp; guided, the same time leaves several times less. Each is checked
# against an unguided reference of the scene at the same scale where one exists already (the REF_SPP one,
# or any $(REF_DIR)/<name>-s<SCALE>-unguided-*.exr; nothing is rendered for the check).
REF_GUIDED ?=
# REF_CONNECT=auto: the guided references with caustic connections weighed by the pilot (default off: see
# scripts/bench.py reference), for scenes where without them a reference stays too noisy to judge by.
REF_CONNECT ?= off
ref_unguided = $(REF_DIR)/$(1)-s$(SCALE)-$(call ref_spp,$(1))spp.exr
ref_of = $(if $(REF_GUIDED),$(REF_DIR)/$(1)-s$(SCALE)-guided-$(REF_GUIDED)s$(if $(filter auto,$(REF_CONNECT)),-connect).exr,$(call ref_unguided,$(1)))
ref_args = $(if $(REF_GUIDED),--guided-seconds $(REF_GUIDED) --connect $(REF_CONNECT),--spp $(call ref_spp,$(1)))
ref_check_file = $(firstword $(wildcard $(call ref_unguided,$(1)) $(REF_DIR)/$(1)-s$(SCALE)-unguided-*.exr))
ref_check = $(if $(and $(REF_GUIDED),$(call ref_check_file,$(1))),--check-reference $(call ref_check_file,$(1)))
REFS := $(foreach s,$(SCENES_ALL),$(call ref_of,$(call name_of,$(s))))
RESULTS := $(foreach s,$(SCENES_ALL),$(RUNS)/$(call name_of,$(s))/results.json)

# Parameter studies (the thesis's: photon paths, cache count, photons per cache, map resolution, filter),
# one guided.mk setting at a time, at the quick tier's scale and largest budget.
PARAM_SCENE ?= cbox_kugeln
PARAM_BUDGET ?= 24
PARAM_STUDY ?= PATHS=62500,125000,250000,500000;COUNT=1000,4000,16000;K=250,500,1000,2000;RES=8,16,32;SIGMA=0,0.75,1.5

.PHONY: plots quick full references runs report params targets glazed hybrid product sampler guide-depth connect-choice ab FORCE
# The pixel sampler (render --sampler sobol, the default) against independent samples, unguided and guided,
# from the spread across 6 seeds at 64 spp on the ring, the glass spheres and the plain box. Report
# docs/benchmarks/sampler.md (~12 min).
sampler:
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench_sampler.py --out out/bench/sampler -o docs/benchmarks/sampler.md
# How many vertices to guide: the first alone against every vertex at equal time (30 s, 3 seeds) on the glass
# spheres, the ring and the window room; what render's kShallowMargin rests on. docs/benchmarks/guide-depth.md
# (~12 min).
guide-depth:
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench_choice.py --choice depth --out out/bench/guide-depth -o docs/benchmarks/guide-depth.md
# Caustic connections or not, when every vertex is guided: without against with at equal time (30 s, 4 seeds)
# on the egg, the mirror boxes, the glass spheres and the ring; what render's take_connections rests on.
# docs/benchmarks/connect-choice.md (~20 min).
connect-choice:
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench_choice.py --choice connect --seeds 4 --out out/bench/connect-choice -o docs/benchmarks/connect-choice.md
# Two builds of render side by side (a change that keeps the image and alters noise or cost): OLD_BIN is the
# baseline's bin folder (a worktree of an earlier commit, built the same way), WHAT says what changed.
# Unguided on the plain box, the panel box, the door; unguided and guided on the spheres and the egg;
# 64 spp, 6 seeds. Report docs/benchmarks/$(AB_REPORT).md (~10 min). docs/benchmarks/lights.md is
#   make -f pipelines/bench.mk ab OLD_BIN=/tmp/old/build/bin AB_REPORT=lights \
#       WHAT='solid-angle sampling of mesh-light triangles above 0.1 sr (Arvo 1995)'
# with OLD_BIN built at cc7b6f9.
AB_REPORT ?= ab
ab:
	@test -n "$(OLD_BIN)" || { echo "bench.mk: ab needs OLD_BIN=<bin folder of the baseline build>" >&2; exit 2; }
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench_ab.py --old-bin $(OLD_BIN) --what "$(WHAT)" --spp 64 --seeds 6 \
		--out out/bench/ab -o docs/benchmarks/$(AB_REPORT).md
# Issue 25, part 1: hybrid caches (render --learn) against photon-only caches on the room lit through a
# door, with scarce (25k paths) and default photons. Report docs/benchmarks/hybrid-door.md (~25 min).
hybrid:
	BIN=$(BIN) PYTHON=$(PYTHON) REF_DIR=$(REF_DIR) bash scripts/bench-hybrid-door.sh
# Issue 25, part 2: product sampling with glossy lobes (render --product on) against the map alone on the
# glossy spheres box. Report docs/benchmarks/product.md (~25 min).
product:
	BIN=$(BIN) PYTHON=$(PYTHON) REF_DIR=$(REF_DIR) bash scripts/bench-product.sh
# Issue 25's equal-time targets at half size (the spec glass box is cbox_kugeln at 256 x 256): the four
# caustic seed scenes against guided references of 300 s (made without caustic connections, so that they
# do not share the renders' technique), budgets 30/60 s, 2 repeats; the two scenes without caustics against
# unguided references of 1024 spp, budgets 15/30 s, 3 repeats; the two modes the targets compare. Reports
# docs/benchmarks/targets-connect.md and targets-plain.md (~40 min + references). targets-caustics.md is
# the same measurement before caustic connections (420-s references, 15/30/60 s, 3 repeats).
# The room lit through a glazed window (scenes/window_room/window_room_glazed.xml: a thin pane that
# shadow rays do not pass, the sky's light a caustic everywhere in the room) at its own 320 x 240, 30/60 s,
# 2 repeats, against a guided reference of 600 s with connections. Report docs/benchmarks/glazed-room.md
# (~20 min with its reference). ROOM=window_room: the same for the room with the open window
# (docs/benchmarks/window-room-connect.md).
ROOM ?= window_room_glazed
glazed:
	@$(MAKE) -f pipelines/bench.mk TIER=glazed SEEDS=scenes SCENES_ALL='$(ROOM):window_room/$(ROOM).xml' \
	  SCALE=1 REF_GUIDED=600 REF_CONNECT=auto BUDGETS=30,60 MODES=nee+bsdf,auto REPEATS=2 \
	  REPORT=$(if $(filter window_room_glazed,$(ROOM)),glazed-room,$(subst _,-,$(ROOM))-connect) report
targets:
	@$(MAKE) -f pipelines/bench.mk TIER=quick REF_GUIDED=300 BUDGETS=30,60 MODES=nee+bsdf,auto REPEATS=2 \
	  ONLY='cbox_kugeln cbox_spiegelboxen bidir ring' REPORT=targets-connect report
	@$(MAKE) -f pipelines/bench.mk TIER=quick REF_SPP=1024 BUDGETS=15,30 MODES=nee+bsdf,auto REPEATS=3 \
	  ONLY='cbox_nur_box mi' REPORT=targets-plain report
quick:
	@$(MAKE) -f pipelines/bench.mk TIER=quick report
full:
	@$(MAKE) -f pipelines/bench.mk TIER=full report
references: $(REFS)
params: $(call ref_of,$(PARAM_SCENE))
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench.py params --scene $(call path_of,$(filter $(PARAM_SCENE):%,$(SCENES_ALL))) \
	  --name $(PARAM_SCENE) --scale $(SCALE) --budget $(PARAM_BUDGET) --reference $< --study '$(PARAM_STUDY)' \
	  --out out/bench/params/$(PARAM_SCENE) -o docs/benchmarks/params-$(PARAM_SCENE).md
runs: $(RESULTS)

# The settings given on make's command line, quoted in the report's command.
GIVEN := $(foreach v,ROOM SCALE BUDGETS MODES REF_SPP REF_GUIDED REF_CONNECT REPEATS PIPELINE ONLY REPORT,$(if $(filter command line,$(origin $(v))),$(v)='$($(v))'))
report: $(RESULTS)
	$(PYTHON) scripts/bench.py report --tier $(TIER) --runs $(RUNS) -o docs/benchmarks/$(REPORT).md --assets docs/benchmarks/$(REPORT) $(GIVEN)

define scene_rules
$(call ref_of,$(call name_of,$(1))): $(call path_of,$(1))
	@mkdir -p $(REF_DIR)
	@echo "reference $(call name_of,$(1)): $(call ref_args,$(call name_of,$(1))) at scale $(SCALE) (once; kept in $(REF_DIR))"
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench.py reference --scene $(call path_of,$(1)) --scale $(SCALE) \
	  $(call ref_args,$(call name_of,$(1))) -o $$@

$(RUNS)/$(call name_of,$(1))/results.json: $(call ref_of,$(call name_of,$(1))) FORCE
	@echo "runs $(call name_of,$(1)): budgets $(BUDGETS) s, modes $(MODES)"
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench.py runs --scene $(call path_of,$(1)) --name $(call name_of,$(1)) \
	  --scale $(SCALE) --budgets $(BUDGETS) --modes $(MODES) --repeats $(REPEATS) --reference $$< \
	  $(call ref_check,$(call name_of,$(1))) --out $(RUNS)/$(call name_of,$(1)) $(PIPELINE)
endef
$(foreach s,$(SCENES_ALL),$(eval $(call scene_rules,$(s))))

# Re-draws the committed reports' plots from their tables (no renders; the budget on the time axis).
plots:
	$(PYTHON) scripts/bench.py plots $(wildcard docs/benchmarks/full*.md docs/benchmarks/quick*.md)

# A peer in the benchmark (issue 25): iris unguided, iris guided (guided.mk's defaults) and Blender Cycles
# (Debian's package, CPU path tracer, scripts/cycles_render.py, its Gaussian filter matched to iris's:
# scripts/filter_profile.py) at the same ladder of total wall-clock budgets, interleaved per budget and
# repeated PEER_REPEATS times (independent seeds), each against one iris unguided reference per scene that
# the report checks against Cycles' own renders; the report is docs/benchmarks/peers.md with a plot per scene
# (Debian's /usr/bin/python3 has python3-matplotlib and NumPy; scripts/exr.py reads the images).
#   make -f pipelines/bench.mk peers          # the spec glass box at 30/60/120 s, the plain box at 15/30/60 s, 2 repeats (~45 min)
#   make -f pipelines/bench.mk peers PEER_REPEATS=3 PEER_REF_TIME=900
#   make -f pipelines/bench.mk peers-glass    # the spec glass box alone at 30/60 s (~20 min): peers-glass.md
# Blender is a benchmark-only dependency (~300 MB with its data): installed here when missing and run as
# root, never by scripts/install-deps.sh, and no test needs it.
# NAME:scene path. The spec boxes: glass_spheres.xml is the thesis's cbox_kugeln.xml (two glass spheres),
# empty_box.xml the plain box (diffuse walls, no objects); of iris's caustic scenes the mirror boxes
# (copper conductors: Cycles' sharp Glossy with the exact conductor Fresnel as shader math). Not the glass
# egg (veach_bidir: a Ward BSDF and a medium) nor the metal ring (roughdiffuse): no Cycles translation.
PEER_SCENES ?= glass_box:scenes/cbox/glass_spheres.xml plain_box:scenes/cbox/empty_box.xml \
  mirror_boxes:scenes/thesis/cbox_spiegelboxen.xml
PEER_BUDGETS ?= 15,30,60
# The glass box's guided preprocessing took 16-45 s on the shared machine (2026-12-04): its ladder starts at 30 s.
PEER_BUDGETS_glass_box ?= 30,60,120
PEER_BUDGETS_mirror_boxes ?= 30
PEER_REPEATS ?= 2
PEER_SCALE ?= 0.5
# The references are time-bounded (iris unguided, PEER_REF_TIME seconds; the glass box PEER_REF_TIME_glass_box):
# the shared machine's sample rate varies several-fold; compare-images states each reference's own share of
# the relMSE, and the report subtracts it in its "ref noise removed" column.
PEER_REF_TIME ?= 180
PEER_REF_TIME_glass_box ?= 420
PEER_REF_TIME_mirror_boxes ?= 180
BLENDER ?= blender
PEER_RUNS := out/bench/peers
PEER_REPORT ?= peers
peer_path = $(word 2,$(subst :, ,$(1)))
peer_ref_time = $(or $(PEER_REF_TIME_$(1)),$(PEER_REF_TIME))
peer_ref = $(REF_DIR)/peer-$(1)-s$(PEER_SCALE)-$(call peer_ref_time,$(1))s.exr
PEER_GIVEN := $(foreach v,PEER_SCENES PEER_BUDGETS $(foreach s,$(PEER_SCENES),PEER_BUDGETS_$(call name_of,$(s))) PEER_REPEATS \
  PEER_SCALE PEER_REF_TIME PEER_REPORT PIPELINE,$(if $(filter command line,$(origin $(v))),$(v)='$($(v))'))
.PHONY: peers peers-glass peer-blender
peer-blender:
	@command -v $(BLENDER) >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y blender; } || \
	  { echo "bench.mk: error: $(BLENDER) not found; install Debian's package: apt-get install blender" >&2; exit 1; }
peers: $(foreach s,$(PEER_SCENES),$(PEER_RUNS)/$(call name_of,$(s))/results.json) $(PEER_RUNS)/filter_profile.txt
	$(PYTHON) scripts/bench_peers.py report --runs $(PEER_RUNS) \
	  --names $(foreach s,$(PEER_SCENES),$(call name_of,$(s))) -o docs/benchmarks/$(PEER_REPORT).md \
	  --assets docs/benchmarks/$(PEER_REPORT) $(PEER_GIVEN)
# The spec glass box alone at 30/60 s, 2 repeats (~20 min with its reference): docs/benchmarks/peers-glass.md.
peers-glass:
	@$(MAKE) -f pipelines/bench.mk PEER_SCENES=glass_box:scenes/cbox/glass_spheres.xml PEER_BUDGETS_glass_box=30,60 \
	  PEER_REPORT=peers-glass peers
# Both renderers' pixel filter measured on a slanted emitter edge (and Cycles' with the first run's width 6 px).
$(PEER_RUNS)/filter_profile.txt: scripts/filter_profile.py scripts/cycles_render.py peer-blender
	@mkdir -p $(PEER_RUNS)
	IRIS_BIN=$(BIN) BLENDER=$(BLENDER) $(PYTHON) scripts/filter_profile.py --cycles-width 6 > $@.tmp && mv $@.tmp $@
define peer_rules
$(call peer_ref,$(call name_of,$(1))): $(call peer_path,$(1))
	@mkdir -p $(REF_DIR)
	IRIS_BIN=$(BIN) $(PYTHON) scripts/bench_peers.py reference --scene $$< --scale $(PEER_SCALE) \
	  --seconds $(call peer_ref_time,$(call name_of,$(1))) -o $$@
$(PEER_RUNS)/$(call name_of,$(1))/results.json: $(call peer_ref,$(call name_of,$(1))) peer-blender FORCE
	IRIS_BIN=$(BIN) BLENDER=$(BLENDER) $(PYTHON) scripts/bench_peers.py runs --scene $(call peer_path,$(1)) \
	  --name $(call name_of,$(1)) --scale $(PEER_SCALE) --budgets $(or $(PEER_BUDGETS_$(call name_of,$(1))),$(PEER_BUDGETS)) \
	  --repeats $(PEER_REPEATS) --reference $$< --out $(PEER_RUNS)/$(call name_of,$(1)) $(PIPELINE)
endef
$(foreach s,$(PEER_SCENES),$(eval $(call peer_rules,$(s))))
