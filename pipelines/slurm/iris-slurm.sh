#!/usr/bin/env bash
# Submits the guided pipeline as Slurm jobs with dependencies, on a file system every node shares:
#
#   photons job array (PHOTON_TASKS x trace-photons --path-range) -> merge-photons -> place-caches
#   -> fill-caches -> render job array (TASKS x render --sample-range) -> merge-images -> OUT/guided.exr
#
#   pipelines/slurm/iris-slurm.sh SCENE=scenes/cbox/glass_spheres.xml OUT=/shared/out/spheres SPP=256 TASKS=8
#
# Parameters (KEY=VALUE arguments or environment), as in pipelines/guided.mk:
#   SCENE OUT BIN SEED RESOLUTION, and the stages' settings (space-separated name=value lists, passed as
#   --set; `TOOL --list-settings` shows them): PHOTONS_SET CACHES_SET ATLAS_SET RENDER_SET GUIDED_SET
#   PHOTONS_SET must fix photon-paths (the path ranges split it)           default 'photon-paths=250000'
#   SPP      samples per pixel in all (a split render has a fixed spp: no TIME)      default 64
#   The render runs with pilot=off (a pilot is measured per process, so the parts would differ): mode
#   nee+bsdf+cache unless RENDER_SET/GUIDED_SET set another, caustics and connections off unless set on.
#   TASKS, PHOTON_TASKS   tasks of the render and photon arrays                      default 4, 2
#   CPUS     CPUs per task (and -t of each tool)                                     default 1
#   RETRIES  times a task's tool is re-run by the task itself after it failed or was killed  default 1
#   SBATCH_FLAGS          extra sbatch flags for every job (partition, account, time limit, ...)
#   WAIT=1   block until every job has left the queue; exit status 0 if OUT/guided.exr was written
# Faults: every job is submitted with --requeue (Slurm re-runs a task whose node failed or that was
# preempted) and each task re-runs its tool up to RETRIES times when it exits non-zero or is killed;
# tools write atomically, so a part is complete or absent, and the merges refuse a missing part (naming
# its range) -- a task that fails for good leaves the merge job's dependency unsatisfied, and Slurm
# cancels it (--kill-on-invalid-dep=yes). Each job's log: OUT/logs/<job>-<array task>.log.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
self="$here/$(basename "$0")"

# One task of an array or one stage, run by Slurm on a node: `iris-slurm.sh task STAGE` with the
# parameters in the environment (sbatch --export=ALL).
if [[ "${1:-}" == task ]]; then
  stage=$2
  id=${SLURM_ARRAY_TASK_ID:-0}
  range() {  # task id of n over total -> "A:B" (contiguous, sizes differ by at most one)
    local n=$1 total=$2
    echo "$(( id * total / n )):$(( (id + 1) * total / n ))"
  }
  run() {  # the tool, re-run up to RETRIES times after a failure or a kill
    local attempt=0
    while :; do
      local status=0
      if [[ -n "${IRIS_SLURM_FAULT:-}" && "$IRIS_SLURM_FAULT" == "$stage:$id" && ! -e "$OUT/logs/fault-$stage-$id" ]]; then
        # Fault injection for tests: the first attempt of this task is killed (SIGKILL) as it starts
        # (counted as killed even where it won the race and finished).
        touch "$OUT/logs/fault-$stage-$id"
        "$@" & local pid=$!
        kill -KILL "$pid" 2>/dev/null || true
        wait "$pid" || true
        status=137
      else
        "$@" || status=$?
      fi
      [[ $status == 0 ]] && return 0
      echo "iris-slurm: $stage task $id: exit status $status (attempt $((attempt + 1)) of $((RETRIES + 1)))" >&2
      attempt=$((attempt + 1))
      (( attempt > RETRIES )) && return "$status"
    done
  }
  common=(--seed "$SEED" -t "$CPUS" -q)
  sets() { for a in "$@"; do printf -- '--set\n%s\n' "$a"; done; }  # name=value ... -> --set name=value ...
  size=(); [[ -n $RESOLUTION ]] && size=(--resolution "$RESOLUTION")
  # shellcheck disable=SC2086  # the *_SET variables are lists of name=value
  { mapfile -t photons_set < <(sets $PHOTONS_SET); mapfile -t caches_set < <(sets $CACHES_SET)
    mapfile -t atlas_set < <(sets $ATLAS_SET); mapfile -t render_set < <(sets pilot=off $RENDER_SET $GUIDED_SET); }
  case $stage in
    photons)
      run "$BIN/trace-photons" "$SCENE" -o "$OUT/parts/photons-$id.h5" "${photons_set[@]}" \
        --path-range "$(range "$PHOTON_TASKS" "$PATHS")" "${common[@]}" ;;
    merge-photons)
      parts=(); for ((i = 0; i < PHOTON_TASKS; ++i)); do parts+=("$OUT/parts/photons-$i.h5"); done
      run "$BIN/merge-photons" "${parts[@]}" -o "$OUT/photons.h5" -q ;;
    caches)
      run "$BIN/place-caches" "$SCENE" --photon-map "$OUT/photons.h5" -o "$OUT/caches.h5" "${caches_set[@]}" \
        "${size[@]}" --no-scene-warnings "${common[@]}" ;;
    atlas)
      run "$BIN/fill-caches" "$OUT/caches.h5" --photon-map "$OUT/photons.h5" -o "$OUT/atlas.h5" "${atlas_set[@]}" \
        "${common[@]}" ;;
    render)
      run "$BIN/render" "$SCENE" --atlas "$OUT/atlas.h5" "${render_set[@]}" --spp "$SPP" \
        --sample-range "$(range "$TASKS" "$SPP")" --variance "${size[@]}" --no-scene-warnings \
        -o "$OUT/parts/render-$id.exr" "${common[@]}" ;;
    merge-images)
      parts=(); for ((i = 0; i < TASKS; ++i)); do parts+=("$OUT/parts/render-$i.exr"); done
      run "$BIN/merge-images" "${parts[@]}" -o "$OUT/guided.exr" -q ;;
    *) echo "iris-slurm: error: unknown stage '$stage'" >&2; exit 2 ;;
  esac
  exit 0
fi

for arg in "$@"; do
  [[ "$arg" == *=* ]] || { echo "iris-slurm: error: arguments are KEY=VALUE, got '$arg'" >&2; exit 2; }
  export "${arg?}"
done
root=$(cd "$here/../.." && pwd)
export SCENE=${SCENE:-$root/scenes/cbox/glass_spheres.xml}
export OUT=${OUT:-$root/out/slurm/$(basename "${SCENE%.*}")}
export BIN=${BIN:-$root/build/bin} SEED=${SEED:-1}
export RESOLUTION=${RESOLUTION:-} PHOTONS_SET=${PHOTONS_SET:-photon-paths=250000}
export CACHES_SET=${CACHES_SET:-} ATLAS_SET=${ATLAS_SET:-} RENDER_SET=${RENDER_SET:-} GUIDED_SET=${GUIDED_SET:-}
export SPP=${SPP:-64}
export TASKS=${TASKS:-4} PHOTON_TASKS=${PHOTON_TASKS:-2} CPUS=${CPUS:-1} RETRIES=${RETRIES:-1}
# The photon path count the ranges split (the last photon-paths= of PHOTONS_SET).
PATHS=$(tr ' ' '\n' <<<"$PHOTONS_SET" | sed -n 's/^photon-paths=//p' | tail -1)
export PATHS
SBATCH_FLAGS=${SBATCH_FLAGS:-}
WAIT=${WAIT:-0}
err() { echo "iris-slurm: error: $*" >&2; exit 2; }
[[ -n $PATHS ]] || err "PHOTONS_SET must set photon-paths (the photon path ranges split it), got '$PHOTONS_SET'"
[[ " $RENDER_SET $GUIDED_SET " == *" pilot=on "* ]] && err "pilot=on cannot be split into sample ranges (the pilot is measured per process)"
for v in SPP TASKS PHOTON_TASKS CPUS PATHS; do [[ ${!v} =~ ^[1-9][0-9]*$ ]] || err "$v must be a positive integer, got '${!v}'"; done
(( TASKS <= SPP )) || err "TASKS ($TASKS) must not exceed SPP ($SPP)"
(( PHOTON_TASKS <= PATHS )) || err "PHOTON_TASKS ($PHOTON_TASKS) must not exceed PATHS ($PATHS)"
[[ -f $SCENE ]] || err "$SCENE: scene file does not exist"
for t in trace-photons merge-photons place-caches fill-caches render merge-images; do
  [[ -x $BIN/$t ]] || err "$BIN/$t: not built (cmake --build build)"
done
command -v sbatch >/dev/null || err "sbatch not found: Slurm's client commands are needed (Debian: slurm-client)"
mkdir -p "$OUT/parts" "$OUT/logs"
# A new run: stale parts of an earlier one must not be merged (they would be refused anyway if their
# settings differ; if they agree they are the same samples).
rm -f "$OUT"/parts/* "$OUT"/logs/fault-* "$OUT/guided.exr"

# shellcheck disable=SC2086  # SBATCH_FLAGS is a list of flags
submit() {  # NAME DEPENDENCY ARRAY_SIZE [--wait] -> job id
  local name=$1 dep=$2 n=$3; shift 3
  local flags=(--parsable --export=ALL --requeue --kill-on-invalid-dep=yes --job-name "iris-$name"
               --cpus-per-task "$CPUS" --open-mode=append)
  [[ -n $dep ]] && flags+=(--dependency "afterok:$dep")
  if (( n > 1 )); then flags+=(--array "0-$((n - 1))" --output "$OUT/logs/$name-%a.log")
  else flags+=(--output "$OUT/logs/$name.log"); fi
  sbatch "${flags[@]}" $SBATCH_FLAGS "$@" "$self" task "$name" | cut -d';' -f1
}
j1=$(submit photons "" "$PHOTON_TASKS")
j2=$(submit merge-photons "$j1" 1)
j3=$(submit caches "$j2" 1)
j4=$(submit atlas "$j3" 1)
j5=$(submit render "$j4" "$TASKS")
echo "iris-slurm: submitted photons $j1 (x$PHOTON_TASKS), merge-photons $j2, place-caches $j3, fill-caches $j4," \
     "render $j5 (x$TASKS, $SPP spp), merge-images (next); output $OUT/guided.exr" >&2
if [[ $WAIT == 1 ]]; then
  # Poll squeue once a second (sbatch --wait backs off to ~30 s between polls on a 10 s pipeline).
  j6=$(submit merge-images "$j5" 1)
  while [[ -n $(squeue -h -j "$j1,$j2,$j3,$j4,$j5,$j6" -o %i 2>/dev/null) ]]; do sleep 1; done
  [[ -f $OUT/guided.exr ]] || { echo "iris-slurm: error: the pipeline failed (see $OUT/logs/)" >&2; exit 1; }
  echo "iris-slurm: done, $OUT/guided.exr (merge job $j6)" >&2
else
  submit merge-images "$j5" 1
fi
