#!/usr/bin/env bash
# A real one-node Slurm cluster on 127.0.0.1 (munged, slurmctld, slurmd with 2 CPUs; state, spool,
# logs and the munge key in a temporary folder), the guided pipeline submitted through
# pipelines/slurm/iris-slurm.sh with a 2-task render array (one task killed on its first attempt and
# re-run), and the merged image checked against a single-process run of the same stages. Stops the
# daemons it started. Exit 77 (ctest: skipped) where Slurm is missing or cannot start and we are not
# root; as root it installs slurm-wlm and munge from Debian when missing, and then must pass.
#   tests/slurm/run-cluster-test.sh BIN_DIR        (BENCH=1 also times a 4-task array against one process)
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
BIN=$(cd "${1:-$root/build/bin}" && pwd)
skip() { echo "slurm-cluster-test: skipped: $*"; exit 77; }
fail() { echo "slurm-cluster-test: FAILED: $*"; [[ -n ${T:-} ]] && tail -n 20 "$T"/log/*.log "$T"/out/logs/*.log 2>/dev/null; exit 1; }
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
  [[ $(id -u) == 0 ]] || skip "slurm-wlm and munge are not installed and we are not root"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null ||
    fail "apt-get install slurm-wlm munge"
fi
[[ $(id -u) == 0 ]] || skip "not root: slurmd must run as root to start jobs as their users"

T=$(mktemp -d /tmp/iris-slurm-XXXXXX)
chmod 755 "$T"
mkdir -p "$T"/{state,spool,log,munge,out}
pids=()
cleanup() {
  # Only the daemons this script started, by their process ids.
  for ((i = ${#pids[@]} - 1; i >= 0; --i)); do kill "${pids[i]}" 2>/dev/null; done
  for p in "${pids[@]}"; do for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done; kill -9 "$p" 2>/dev/null; done
  [[ ${KEEP:-0} == 1 ]] || rm -rf "$T"
}
trap cleanup EXIT

# munge: its own key and socket.
dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 status=none
chmod 700 "$T/munge"; chmod 400 "$T/munge/munge.key"
sock="$T/munge/munge.socket"
munged --force --key-file="$T/munge/munge.key" --socket="$sock" --pid-file="$T/munge/munged.pid" \
  --log-file="$T/log/munged.log" --seed-file="$T/munge/seed" || fail "munged did not start"
for _ in $(seq 50); do [[ -s $T/munge/munged.pid ]] && break; sleep 0.1; done
pids+=("$(cat "$T/munge/munged.pid")")

# Free ports for the controller and the node daemon (another cluster may use the defaults).
port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
ctl_port=$(port); d_port=$(port)
hw=$(slurmd -C | head -1)
mem=$(sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' <<<"$hw")
cpus_hw=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$hw")
cpus=$(( cpus_hw < 2 ? cpus_hw : 2 ))
export SLURM_CONF="$T/slurm.conf"
cat > "$SLURM_CONF" <<CONF
ClusterName=iristest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctl_port
SlurmdPort=$d_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
JobRequeue=1
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
MaxJobCount=1000
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=iris Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -i -f "$SLURM_CONF" >"$T/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N localhost -f "$SLURM_CONF" >"$T/log/slurmd.out" 2>&1 &
pids+=($!)
up=0
for _ in $(seq 120); do
  sinfo -h -N -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && { up=1; break; }
  sleep 0.5
done
[[ $up == 1 ]] || fail "the node did not come up: $(sinfo -h -N -o '%T %E' 2>&1)"
echo "slurm-cluster-test: cluster up ($cpus CPUs, $mem MB, ports $ctl_port/$d_port)"

# The pipeline, small: the caustic box at 32x32, 16 spp in 2 render tasks (task 1 killed once).
scene="$root/tests/data/guiding/caustic_box.xml"
params=(SCENE="$scene" BIN="$BIN" SEED=7 PHOTONS_SET="photon-paths=4000 photon-depth=6" PHOTON_TASKS=2
        CACHES_SET="cache-count=64" ATLAS_SET="gather-count=64 map-resolution=8 max-radius=0.15"
        SPP=16 CPUS=1 RETRIES=1 RESOLUTION=32x32)
start=$(date +%s.%N)
IRIS_SLURM_FAULT=render:1 WAIT=1 "$root/pipelines/slurm/iris-slurm.sh" "${params[@]}" OUT="$T/out" TASKS=2 ||
  fail "the pipeline did not finish"
echo "slurm-cluster-test: pipeline on the cluster took $(echo "$(date +%s.%N) - $start" | bc) s"
grep -q "render task 1: exit status 137" "$T/out/logs/render-1.log" || fail "the injected kill of render task 1 did not happen"

# The same stages in one process each, and the comparison.
S="$T/single"; mkdir -p "$S"
c=(--seed 7 -q)
"$BIN/trace-photons" "$scene" -o "$S/photons.h5" --set photon-paths=4000 --set photon-depth=6 "${c[@]}" &&
"$BIN/place-caches" "$scene" --photon-map "$S/photons.h5" -o "$S/caches.h5" --set cache-count=64 --resolution 32x32 "${c[@]}" &&
"$BIN/fill-caches" "$S/caches.h5" --photon-map "$S/photons.h5" -o "$S/atlas.h5" --set gather-count=64 --set map-resolution=8 \
  --set max-radius=0.15 "${c[@]}" &&
"$BIN/render" "$scene" --atlas "$S/atlas.h5" --set pilot=off --spp 16 \
  --variance --resolution 32x32 -o "$S/guided.exr" "${c[@]}" || fail "the single-process pipeline failed"
for d in position direction normal power; do
  cmp -s <(h5dump -d "$d" "$S/photons.h5" | tail -n +3) <(h5dump -d "$d" "$T/out/photons.h5" | tail -n +3) ||
    fail "merged photon map's '$d' differs from the single run's"
done
"$BIN/compare-images" "$T/out/guided.exr" "$S/guided.exr" --max-relmse 1e-12 > "$T/compare.txt" ||
  { cat "$T/compare.txt"; fail "the merged image differs from the single-process image"; }
echo "slurm-cluster-test: merged image against the single process: $(grep '^relMSE  ' "$T/compare.txt")"
# A missing part is named, nothing is written.
if out=$("$BIN/merge-images" "$T/out/parts/render-0.exr" -o "$T/partial.exr" 2>&1); then fail "merge took a missing part"; fi
[[ $out == *"samples 8:16 missing"* && ! -e $T/partial.exr ]] || fail "merge of a missing part said: $out"

if [[ ${BENCH:-0} == 1 ]]; then
  # Overhead: a 4-task render array (1 CPU per task, 2 at a time on the 2 CPUs) against one process
  # with 2 threads, same image; the stages before it are shared (same atlas).
  bparams=("${params[@]}" SPP=${BENCH_SPP:-256} RESOLUTION="${BENCH_RES:-128x128}")
  t0=$(date +%s.%N)
  "$BIN/render" "$scene" --atlas "$S/atlas.h5" --set pilot=off --spp "${BENCH_SPP:-256}" --variance \
    --resolution "${BENCH_RES:-128x128}" -t 2 -o "$S/bench.exr" "${c[@]}"
  t1=$(date +%s.%N)
  echo "slurm-cluster-test: bench: one process, -t 2: $(echo "$t1 - $t0" | bc) s"
  # Only the render array and its merge: photons..atlas are re-run by the script but timed apart.
  t0=$(date +%s.%N)
  WAIT=1 "$root/pipelines/slurm/iris-slurm.sh" "${bparams[@]}" OUT="$T/bench" TASKS=4
  t1=$(date +%s.%N)
  echo "slurm-cluster-test: bench: whole pipeline with a 4-task render array: $(echo "$t1 - $t0" | bc) s"
  grep -h . "$T"/bench/logs/*.log | head -5
  "$BIN/compare-images" "$T/bench/guided.exr" "$S/bench.exr" | head -1
fi
echo "slurm-cluster-test: passed"
