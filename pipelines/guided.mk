# The guided pipeline: trace-photons -> place-caches -> fill-caches -> render --atlas, with the unguided
# render at the same total time beside it and a comparison against a reference.
#
#   make -f pipelines/guided.mk SCENE=scenes/cbox/glass_spheres.xml OUT=out/glass_spheres [targets]
#
# Targets: photons caches atlas guided (default) unguided reference compare clean
# Every parameter below can be overridden on the command line (make ... K=500 TIME=120).
# Each stage's full command line is kept in $(OUT)/<stage>.params; a stage re-runs when its command
# (i.e. a parameter) or an input changed, and so do the stages after it - nothing else re-runs.
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

# trace-photons: as many paths as store about PHOTONS photons (trace-photons --photons), or exactly PATHS
# paths where PATHS is given. Photons per path range from 0.3 (the metal ring: an open scene) to 3.4 (the
# Veach bidir room), and the caches need photons near them: at 250000 paths the ring's caches were built
# from 83k photons, and 500k (1.5M paths, +1 s) left 20 % less variance per sample (DESIGN 6.9); the
# closed boxes store about 500k at 250000 paths already.
PHOTONS ?= 500000
PATHS ?=
PHOTON_DEPTH ?= 30
# place-caches
COUNT ?= 4000
STRIDE ?= 8
# No caches at all (an unguided render) when less than this share of the photon power arrives through
# specular chains: on the seed scenes without any (the plain box, the plates) guiding did not pay for
# its preprocessing. 0 = always guide. Where no surface has a specular lobe (the plain box) the share is
# 0 without tracing, and trace-photons traces nothing.
MIN_CAUSTIC ?= 0.005
# fill-caches
K ?= 1000
# 32x32 maps (texels ~6 degrees): at equal spp, guiding every vertex with them left 35-45 % less error
# than 16x16 on the glass spheres and the mirror boxes (first vertex: 24-29 % less on the ring and the
# egg), for 5-10 % more time per sample; 24 and 64 were less efficient on the spheres (BENCHMARKS.md).
RES ?= 32
SIGMA ?= 0.75
FLOOR ?= 0.1
MAX_RADIUS ?= 0.05
# render
TIME ?= 30
SPP ?= 0
MODE ?= auto
BSDF_FRACTION ?= auto
# Light tracing of the caustics seen directly (render --caustics): auto (MODE=auto's default: where they
# are at least 0.1 % of the image or the pilot predicts a gain) | on | off.
CAUSTICS ?= $(if $(filter auto,$(MODE)),auto,off)
# Extra render flags: RENDER_FLAGS for both renders, GUIDE_FLAGS for the guided one only (e.g. hybrid
# caches where photons reach the visible part badly, with a fixed guided mode:
#   MODE=nee+bsdf+cache GUIDE_FLAGS='--learn --guide-vertices 0 --rr-threshold 0.1'; docs/benchmarks/hybrid.md).
RENDER_FLAGS ?=
GUIDE_FLAGS ?=
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

CMD_photons = $(BIN)/trace-photons $(SCENE) -o $(OUT)/photons.h5 $(if $(PATHS),--paths $(PATHS),--photons $(PHOTONS)) --max-depth $(PHOTON_DEPTH) \
  --min-caustic-share $(MIN_CAUSTIC) $(COMMON)
CMD_caches = $(BIN)/place-caches $(SCENE) --photons $(OUT)/photons.h5 -o $(OUT)/caches.h5 --count $(COUNT) \
  --camera-stride $(STRIDE) --min-caustic-share $(MIN_CAUSTIC) $(SIZE) $(NOWARN) $(COMMON)
CMD_atlas = $(BIN)/fill-caches $(OUT)/caches.h5 --photons $(OUT)/photons.h5 -o $(OUT)/atlas.h5 --k $(K) \
  --resolution $(RES) --filter-sigma $(SIGMA) --floor $(FLOOR) --max-radius $(MAX_RADIUS) \
  $(if $(filter bsdf+cache,$(MODE)),--direct) $(COMMON)
CMD_guided = $(BIN)/render $(SCENE) --atlas $(OUT)/atlas.h5 --mode $(MODE) --bsdf-fraction $(BSDF_FRACTION) --caustics $(CAUSTICS) \
  -o $(OUT)/guided.exr $(BUDGET) --variance $(SIZE) $(RENDER_FLAGS) $(GUIDE_FLAGS) $(NOWARN) $(COMMON)
# The unguided budget is completed at run time with the measured preprocessing seconds.
CMD_unguided = $(BIN)/render $(SCENE) -o $(OUT)/unguided.exr --mode nee+bsdf --variance $(SIZE) $(RENDER_FLAGS) $(NOWARN) $(COMMON)
CMD_reference = $(BIN)/render $(SCENE) -o $(REF) --mode nee+bsdf --spp $(REF_SPP) --seed 1000003 $(SIZE) -t $(THREADS) $(NOWARN) $(QUIET)

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
	@echo "[1/4] trace-photons: $(if $(PATHS),$(PATHS) paths,about $(PHOTONS) photons)"
	@$(call timed,$(OUT)/photons.seconds,$(CMD_photons))

$(OUT)/caches.h5: $(OUT)/caches.params $(OUT)/photons.h5
	@echo "[2/4] place-caches: $(COUNT) caches"
	@$(call timed,$(OUT)/caches.seconds,$(CMD_caches))

$(OUT)/atlas.h5: $(OUT)/atlas.params $(OUT)/caches.h5 $(OUT)/photons.h5
	@echo "[3/4] fill-caches: k = $(K), $(RES)x$(RES) maps"
	@$(call timed,$(OUT)/atlas.seconds,$(CMD_atlas))

$(OUT)/guided.exr: $(OUT)/guided.params $(OUT)/atlas.h5 $(SCENE)
	@echo "[4/4] render (guided, $(MODE)): $(BUDGET)"
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
	   echo; echo "== guided ($(MODE)), $(TIME) s render + preprocessing =="; \
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
