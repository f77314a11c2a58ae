# Run time against error for the seed scenes (issue 4): references, ladders of equal-time renders per
# mode, and the report (docs/benchmarks/<tier>.md with SVG plots and image crops).
#
#   make -f pipelines/bench.mk quick        # half resolution, budgets 6/12/24 s, 3 modes (~15 min + references)
#   make -f pipelines/bench.mk full         # full resolution, budgets 15..120 s, all modes (~2 h + references)
#   make -f pipelines/bench.mk full MODES=nee+bsdf,auto   # the two modes the targets compare (~50 min)
#   make -f pipelines/bench.mk references TIER=quick   # only the references
#   make -f pipelines/bench.mk params PARAM_SCENE=cbox_kugeln   # parameter studies on one scene (~10 min)
#
# References are unguided long renders (the path tracer alone, independent of the guiding code), kept
# outside git in $(REF_DIR) with a manifest (scene, fingerprint, resolution, spp, seconds, command); make
# rebuilds one only when its scene file changes. The per-scene runs always re-run (they are the
# measurement); run them on an otherwise idle machine, one at a time (no -j): they are timed.

SHELL := /bin/bash
.DELETE_ON_ERROR:

BIN ?= build/bin
SHARED ?= ../shared
SEEDS := $(SHARED)/seed-scenes
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
# Settings passed to pipelines/guided.mk for the preprocessing (empty: its defaults).
PIPELINE ?=

RUNS := out/bench/$(TIER)
name_of = $(word 1,$(subst :, ,$(1)))
path_of = $(SEEDS)/$(word 2,$(subst :, ,$(1)))
REFS := $(foreach s,$(SCENES_ALL),$(REF_DIR)/$(call name_of,$(s))-s$(SCALE)-$(REF_SPP)spp.exr)
RESULTS := $(foreach s,$(SCENES_ALL),$(RUNS)/$(call name_of,$(s))/results.json)

# Parameter studies (the thesis's: photon paths, cache count, photons per cache, map resolution, filter),
# one guided.mk setting at a time, at the quick tier's scale and largest budget.
PARAM_SCENE ?= cbox_kugeln
PARAM_BUDGET ?= 24
PARAM_STUDY ?= PATHS=62500,125000,250000,500000;COUNT=1000,4000,16000;K=250,500,1000,2000;RES=8,16,32;SIGMA=0,0.75,1.5

.PHONY: quick full references runs report params FORCE
quick:
	@$(MAKE) -f pipelines/bench.mk TIER=quick report
full:
	@$(MAKE) -f pipelines/bench.mk TIER=full report
references: $(REFS)
params: $(REF_DIR)/$(PARAM_SCENE)-s$(SCALE)-$(REF_SPP)spp.exr
	IRIS_BIN=$(BIN) python3 scripts/bench.py params --scene $(call path_of,$(filter $(PARAM_SCENE):%,$(SCENES_ALL))) \
	  --name $(PARAM_SCENE) --scale $(SCALE) --budget $(PARAM_BUDGET) --reference $< --study '$(PARAM_STUDY)' \
	  --out out/bench/params/$(PARAM_SCENE) -o docs/benchmarks/params-$(PARAM_SCENE).md
runs: $(RESULTS)

# The settings given on make's command line, quoted in the report's command.
GIVEN := $(foreach v,SCALE BUDGETS MODES REF_SPP PIPELINE,$(if $(filter command line,$(origin $(v))),$(v)='$($(v))'))
report: $(RESULTS)
	python3 scripts/bench.py report --tier $(TIER) --runs $(RUNS) -o docs/benchmarks/$(TIER).md --assets docs/benchmarks/$(TIER) $(GIVEN)

define scene_rules
$(REF_DIR)/$(call name_of,$(1))-s$(SCALE)-$(REF_SPP)spp.exr: $(call path_of,$(1))
	@mkdir -p $(REF_DIR)
	@echo "reference $(call name_of,$(1)): $(REF_SPP) spp at scale $(SCALE) (once; kept in $(REF_DIR))"
	IRIS_BIN=$(BIN) python3 scripts/bench.py reference --scene $(call path_of,$(1)) --scale $(SCALE) --spp $(REF_SPP) -o $$@

$(RUNS)/$(call name_of,$(1))/results.json: $(REF_DIR)/$(call name_of,$(1))-s$(SCALE)-$(REF_SPP)spp.exr FORCE
	@echo "runs $(call name_of,$(1)): budgets $(BUDGETS) s, modes $(MODES)"
	IRIS_BIN=$(BIN) python3 scripts/bench.py runs --scene $(call path_of,$(1)) --name $(call name_of,$(1)) \
	  --scale $(SCALE) --budgets $(BUDGETS) --modes $(MODES) --reference $$< --out $(RUNS)/$(call name_of,$(1)) $(PIPELINE)
endef
$(foreach s,$(SCENES_ALL),$(eval $(call scene_rules,$(s))))
