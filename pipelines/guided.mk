# The guided pipeline: trace-photons -> place-caches -> fill-caches -> render --atlas, with the unguided
# render at the same total time beside it and a comparison against a reference.
#
#   make -f pipelines/guided.mk SCENE=scenes/cbox/glass_spheres.xml OUT=out/glass_spheres [targets]
#
# Targets: photons caches atlas guided (default) unguided reference compare clean
# The stages run with the tools' own defaults (the recommended settings: `TOOL --list-settings`); change
# one with the tool's setting name, per stage, e.g.
#   make -f pipelines/guided.mk ... PHOTONS_SET='photon-count=1000000' ATLAS_SET='gather-count=500'
#   PHOTONS_SET  trace-photons   CACHES_SET  place-caches   ATLAS_SET  fill-caches
#   RENDER_SET   both renders    GUIDED_SET  the guided render only (e.g. 'pilot=off mode=nee+bsdf+cache')
# (min-caustic-share is read by trace-photons and place-caches: give it in PHOTONS_SET and CACHES_SET.)
# Each is a space-separated list of name=value, passed as --set name=value. Running the stages one by
# one with the same settings makes the same files.
# Each stage's full command line is kept in $(OUT)/<stage>.params; a stage re-runs when its command
# (i.e. a setting) or an input changed, and so do the stages after it - nothing else re-runs.
#
# Equal time: the guided render gets TIME seconds; the unguided one gets TIME plus the measured
# preprocessing time (trace-photons + place-caches + fill-caches, in $(OUT)/*.seconds), so both
# images cost the same total wall time.

SHELL := /bin/bash
.DELETE_ON_ERROR:

BIN ?= build/bin
SCENE ?= scenes/cbox/glass_spheres.xml
NAME ?= $(basename $(notdir $(SCENE)))
OUT ?= out/$(NAME)
SEED ?= 1
THREADS ?= 0
QUIET ?= -q
# The image size WxH (empty: the scene's film). place-caches puts its camera caches on this image's
# pixel blocks, and every render (guided, unguided, the reference) is made at it.
RESOLUTION ?=
# The render budget: TIME seconds, or SPP samples per pixel where SPP is not 0.
TIME ?= 30
SPP ?= 0
# The stages' settings (empty: the tools' defaults).
PHOTONS_SET ?=
CACHES_SET ?=
ATLAS_SET ?=
RENDER_SET ?=
GUIDED_SET ?=
# reference (unguided, long), kept outside the output folder so several runs share it
REF_SPP ?= 1024
REF_DIR ?= .cache/references
REF := $(REF_DIR)/$(NAME)$(if $(RESOLUTION),-$(RESOLUTION))-$(REF_SPP)spp.exr

COMMON := --seed $(SEED) -t $(THREADS) $(QUIET)
# The scene's warnings (parameters iris ignores) are printed once, by trace-photons; the later stages read
# the same scene and stay quiet about them. trace-photons re-runs whenever the scene file changes, so the
# warnings show whenever they can have changed (`make ... photons` after deleting photons.h5 repeats them).
NOWARN := --no-scene-warnings
BUDGET := $(if $(filter 0,$(SPP)),--time $(TIME),--spp $(SPP))
SIZE := $(if $(RESOLUTION),--resolution $(RESOLUTION))
# name=value ... -> --set name=value ...
sets = $(foreach a,$(1),--set $(a))

CMD_photons = $(BIN)/trace-photons $(SCENE) -o $(OUT)/photons.h5 $(call sets,$(PHOTONS_SET)) $(COMMON)
CMD_caches = $(BIN)/place-caches $(SCENE) --photon-map $(OUT)/photons.h5 -o $(OUT)/caches.h5 $(call sets,$(CACHES_SET)) \
  $(SIZE) $(NOWARN) $(COMMON)
CMD_atlas = $(BIN)/fill-caches $(OUT)/caches.h5 --photon-map $(OUT)/photons.h5 -o $(OUT)/atlas.h5 $(call sets,$(ATLAS_SET)) $(COMMON)
CMD_guided = $(BIN)/render $(SCENE) --atlas $(OUT)/atlas.h5 -o $(OUT)/guided.exr $(BUDGET) --variance $(SIZE) \
  $(call sets,$(RENDER_SET) $(GUIDED_SET)) $(NOWARN) $(COMMON)
# The unguided budget is completed at run time with the measured preprocessing seconds.
CMD_unguided = $(BIN)/render $(SCENE) -o $(OUT)/unguided.exr --set mode=nee+bsdf --variance $(SIZE) $(call sets,$(RENDER_SET)) \
  $(NOWARN) $(COMMON)
CMD_reference = $(BIN)/render $(SCENE) -o $(REF) --set mode=nee+bsdf --spp $(REF_SPP) --seed 1000003 $(SIZE) -t $(THREADS) $(NOWARN) $(QUIET)

# Runs a command and records its wall time (seconds) in $(1).
timed = start=$$(date +%s.%N); $(2); end=$$(date +%s.%N); awk -v a=$$start -v b=$$end 'BEGIN{printf "%.3f\n", b-a}' > $(1)

.PHONY: all photons caches atlas guided unguided reference compare clean FORCE
all: guided
photons: $(OUT)/photons.h5
caches: $(OUT)/caches.h5
atlas: $(OUT)/atlas.h5
guided: $(OUT)/guided.exr
unguided: $(OUT)/unguided.exr
reference: $(REF)
compare: $(OUT)/comparison.txt

$(OUT) $(REF_DIR):
	@mkdir -p $@

# Parameter stamps: rewritten (and so newer than the stage's output) only when the command changed.
$(OUT)/%.params: FORCE | $(OUT)
	@printf '%s\n' '$(strip $(CMD_$*))' | cmp -s - $@ || printf '%s\n' '$(strip $(CMD_$*))' > $@

$(OUT)/photons.h5: $(OUT)/photons.params $(SCENE)
	@echo "[1/4] trace-photons $(PHOTONS_SET)"
	@$(call timed,$(OUT)/photons.seconds,$(CMD_photons))

$(OUT)/caches.h5: $(OUT)/caches.params $(OUT)/photons.h5
	@echo "[2/4] place-caches $(CACHES_SET)"
	@$(call timed,$(OUT)/caches.seconds,$(CMD_caches))

$(OUT)/atlas.h5: $(OUT)/atlas.params $(OUT)/caches.h5 $(OUT)/photons.h5
	@echo "[3/4] fill-caches $(ATLAS_SET)"
	@$(call timed,$(OUT)/atlas.seconds,$(CMD_atlas))

$(OUT)/guided.exr: $(OUT)/guided.params $(OUT)/atlas.h5 $(SCENE)
	@echo "[4/4] render (guided$(if $(strip $(RENDER_SET) $(GUIDED_SET)),: $(strip $(RENDER_SET) $(GUIDED_SET)))): $(BUDGET)"
	@$(CMD_guided)

# Depends on the atlas too: when preprocessing re-ran, its time changed and so did this budget.
$(OUT)/unguided.exr: $(OUT)/unguided.params $(OUT)/atlas.h5 $(SCENE)
	@prep=$$(cat $(OUT)/photons.seconds $(OUT)/caches.seconds $(OUT)/atlas.seconds | awk '{s+=$$1} END{printf "%.3f", s}'); \
	if [ "$(SPP)" = 0 ]; then budget="--time $$(awk -v t=$(TIME) -v p=$$prep 'BEGIN{printf "%.3f", t+p}')"; else budget="--spp $(SPP)"; fi; \
	echo "render (unguided, nee+bsdf): $$budget (TIME + $$prep s of preprocessing)"; \
	$(CMD_unguided) $$budget

$(REF): $(SCENE) | $(REF_DIR)
	@echo "reference: unguided, $(REF_SPP) spp (once per scene; kept in $(REF_DIR))"
	@$(call timed,$(REF).seconds,$(CMD_reference))
	@{ echo "scene $(SCENE)"; echo "seconds $$(cat $(REF).seconds)"; \
	   $(BIN)/compare-images $(REF) --metadata | grep -E '^iris:(scene_fingerprint|spp|seed|version|command_line) '; \
	 } > $(REF).manifest

$(OUT)/comparison.txt: $(OUT)/guided.exr $(OUT)/unguided.exr $(REF)
	@{ echo "scene: $(SCENE)"; \
	   echo "reference: $(REF) ($(REF_SPP) spp, unguided)"; \
	   echo "preprocessing: $$(cat $(OUT)/photons.seconds) s photons + $$(cat $(OUT)/caches.seconds) s caches + $$(cat $(OUT)/atlas.seconds) s atlas"; \
	   echo; echo "== guided$(if $(strip $(RENDER_SET) $(GUIDED_SET)), ($(strip $(RENDER_SET) $(GUIDED_SET)))), $(TIME) s render + preprocessing =="; \
	   $(BIN)/compare-images $(OUT)/guided.exr --metadata | sed -n 's/^iris:auto_guide /auto: /p'; \
	   $(BIN)/compare-images $(OUT)/guided.exr $(REF) -o $(OUT)/guided.error.png --error-scale 0.05; \
	   echo; echo "== unguided (nee+bsdf), same total time =="; \
	   $(BIN)/compare-images $(OUT)/unguided.exr $(REF) -o $(OUT)/unguided.error.png --error-scale 0.05; \
	   g=$$($(BIN)/compare-images $(OUT)/guided.exr $(REF) --json | sed -n 's/.*"relmse": \([0-9.e+-]*\),.*/\1/p'); \
	   u=$$($(BIN)/compare-images $(OUT)/unguided.exr $(REF) --json | sed -n 's/.*"relmse": \([0-9.e+-]*\),.*/\1/p'); \
	   echo; awk -v g=$$g -v u=$$u 'BEGIN{printf "relMSE unguided / guided at equal total time: %.3f (> 1: guiding wins)\n", u/g}'; \
	} > $@
	@cat $@

clean:
	rm -rf $(OUT)
