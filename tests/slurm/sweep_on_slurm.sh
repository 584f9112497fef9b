#!/usr/bin/env bash
# ctest label slurm: `atacom sweep --slurm` against a real one-node Slurm (cluster.sh).
#   sweep_on_slurm.sh ATACOM_EXE
# 1. the sweep runs locally (the reference);
# 2. a cluster comes up with MaxArraySize=3, and the same 4-run sweep is submitted:
#    two arrays (3 tasks + 1 task), %2 at a time, one run per task;
# 3. task 0 gets the pre-timeout signal (scancel --signal=USR1 --batch, as Slurm sends
#    it for --signal=B:USR1@S) mid-run: its run writes a checkpoint and exits, the task
#    requeues itself, the requeued task resumes the run;
# 4. the second array is cancelled mid-run (scancel: TERM); status names the cell and
#    its log; the same submit command again submits only that cell; a third submit
#    submits nothing;
# 5. every run file equals the local sweep's (wall-clock fields aside), and the
#    cluster goes down (always: trap).
# Exit 77 (ctest SKIP_RETURN_CODE) without root or Slurm, unless ATACOM_REQUIRE_SLURM=1
# (CI), where that is a failure.
set -euo pipefail
export PATH=$PATH:/usr/sbin:/sbin
EXE=$(realpath "${1:?usage: sweep_on_slurm.sh ATACOM_EXE}")
HERE=$(cd "$(dirname "$0")" && pwd)

skip() {
  if [ "${ATACOM_REQUIRE_SLURM:-0}" = 1 ]; then
    echo "FAIL: $* (ATACOM_REQUIRE_SLURM=1: Slurm is required here)"
    exit 1
  fi
  echo "SKIP: $*"
  exit 77
}
[ "$(id -u)" = 0 ] || skip "needs root (starts munged, slurmctld and slurmd); run as root or in CI"
for b in slurmctld slurmd sbatch squeue scontrol scancel sinfo munged mungekey setpriv python3; do
  command -v "$b" >/dev/null || skip "'$b' not found (apt-get install slurmctld slurmd slurm-client munge)"
done
id munge >/dev/null 2>&1 && id slurm >/dev/null 2>&1 || skip "the munge and slurm users do not exist (Debian's packages create them)"

T=$(mktemp -d /tmp/atacom-slurm.XXXXXX)
chmod 755 "$T"
CL=$T/cluster
export SLURM_CONF=$CL/slurm.conf
t0=$(date +%s%N)
phase() { local ms=$(( ($(date +%s%N) - t0) / 1000000 )); printf '[%4d.%d s] %s\n' $((ms / 1000)) $((ms % 1000 / 100)) "$*"; }
fail() { echo "FAIL: $*"; exit 1; }
cleanup() {
  local rc=$?
  if [ $rc != 0 ] && [ $rc != 77 ]; then
    echo "---- diagnostics (exit $rc)"
    for f in "$CL/log/slurmctld.log" "$CL/slurmd.log" "$T"/slurm/slurm/submit-*/task-*.log "$T"/slurm/logs/*.log; do
      [ -f "$f" ] && { echo "---- $f"; tail -n 12 "$f" | cut -c1-300; }
    done
  fi
  bash "$HERE/cluster.sh" down "$CL" || true
  if [ "${ATACOM_KEEP_SLURM_TEST:-0}" = 1 ]; then echo "kept $T"; else rm -rf "$T"; fi
  exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# 4 runs: table x sac, atacom-sac x seeds 0, 1; 16k steps, learning from step 400
# (small nets: a few seconds each), an evaluation (and checkpoint) every 500 steps.
cat > "$T/spec.json" <<'JSON'
{"description": "tests/slurm/sweep_on_slurm.sh", "envs": ["table"], "algos": ["sac", "atacom-sac"],
 "seeds": [0, 1], "steps": 16000, "num_envs": 4,
 "overrides": {"*/*": {"train": {"eval_every": 500, "eval_episodes": 2},
   "sac": {"initial_replay": 400, "warmup": 400, "batch_size": 32,
           "actor": {"hidden": [64, 64]}, "critic": {"hidden": [64, 64]}}}}}
JSON
CELLS=(table/sac/seed-0 table/sac/seed-1 table/atacom-sac/seed-0 table/atacom-sac/seed-1)
NAMES=(table-sac-seed0 table-sac-seed1 table-atacom-sac-seed0 table-atacom-sac-seed1)

phase "local reference sweep"
"$EXE" sweep "$T/spec.json" --out "$T/local" --jobs 2 --threads-per-run 1 2>"$T/local.log" ||
  { cat "$T/local.log"; fail "the local sweep failed"; }

phase "cluster up"
bash "$HERE/cluster.sh" up "$CL" MaxArraySize=3

# Jobs ids are gone from the queue: squeue rc 0 and nothing listed (a dead controller
# also lists nothing, with rc 1).
wait_gone() {
  local ids=$1 limit=$2 out rc
  for _ in $(seq $((limit * 5))); do
    rc=0; out=$(squeue -h -o '%i %t' -j "$ids" 2>&1) || rc=$?
    if [ $rc = 0 ] && [ -z "$out" ]; then return 0; fi
    if [ $rc != 0 ] && ! grep -q "Invalid job id" <<<"$out"; then fail "squeue failed: $out"; fi
    sleep 0.2
  done
  squeue; fail "jobs $ids still queued after $limit s"
}
# A run is mid-way: it has a checkpoint and no summary yet.
wait_mid_run() {
  local run=$T/slurm/runs/$1 limit=$2
  for _ in $(seq $((limit * 20))); do
    [ -f "$run/summary.json" ] && fail "$1 finished before it could be signalled (too fast a machine: raise steps)"
    [ -f "$run/checkpoint.json" ] && return 0
    sleep 0.05
  done
  squeue; fail "$1 did not start within $limit s"
}
job_field() { scontrol show job -o "$1" | tr ' ' '\n' | sed -n "s/^$2=//p" | head -1; }

SUBMIT=("$EXE" sweep "$T/spec.json" --out "$T/slurm" --slurm --cpus-per-task 1 --time 10:00 --max-parallel 2
        --presignal 60)
phase "submit: ${SUBMIT[*]}"
"${SUBMIT[@]}" >"$T/submit1.out" 2>&1 || { cat "$T/submit1.out"; fail "submit failed"; }
cat "$T/submit1.out"
mapfile -t IDS < <(grep -E '^[0-9]+$' "$T/submit1.out")
[ ${#IDS[@]} = 2 ] || fail "4 tasks with MaxArraySize=3 should be 2 arrays, got ${#IDS[@]} job ids"
J1=${IDS[0]} J2=${IDS[1]}
sub1=$(dirname "$(ls "$T"/slurm/slurm/submit-*/tasks.json)")
grep -q -- '--array=0-2%2$' "$sub1/array-0.sbatch" || fail "array-0.sbatch: $(grep array "$sub1/array-0.sbatch")"
grep -q -- '--array=0-0%2$' "$sub1/array-3.sbatch" || fail "array-3.sbatch: $(grep array "$sub1/array-3.sbatch")"
grep -q -- '--task-offset 3 ' "$sub1/array-3.sbatch" || fail "array-3.sbatch does not start at task 3"
# A second submission while the first is queued is refused.
if "${SUBMIT[@]}" >"$T/submit_busy.out" 2>&1; then fail "a submission while jobs are queued was accepted"; fi
grep -q "still queued or running" "$T/submit_busy.out" || fail "refusal: $(cat "$T/submit_busy.out")"

phase "task ${J1}_0 (${CELLS[0]}): waiting for its first checkpoint, then USR1 to the batch shell"
wait_mid_run "${CELLS[0]}" 120
scancel --signal=USR1 --batch "${J1}_0"

phase "array $J2 (${CELLS[3]}): waiting for it to run, then scancel (TERM)"
wait_mid_run "${CELLS[3]}" 180
scancel "$J2"

phase "waiting for both arrays"
wait_gone "$J1,$J2" 300
phase "arrays done"

log0=$(ls "$sub1"/task-"${J1}"_0.log)
grep -q "=== USR1: runs checkpointed (exit 75); requeueing ${J1}_0" "$log0" || { cat "$log0"; fail "task ${J1}_0 did not requeue itself"; }
[ "$(grep -c '^=== task' "$log0")" = 2 ] || { cat "$log0"; fail "task ${J1}_0 should have started twice"; }
grep -q "restart 1" "$log0" || fail "the second start of ${J1}_0 is not restart 1"
[ "$(job_field "${J1}_0" Restarts)" = 1 ] || fail "scontrol: ${J1}_0 Restarts=$(job_field "${J1}_0" Restarts)"
for k in 1 2; do
  [ "$(job_field "${J1}_$k" Restarts)" = 0 ] || fail "${J1}_$k was restarted too (only task 0 was signalled)"
done
cell0=$T/slurm/logs/${NAMES[0]}.log
at=$(sed -n 's/.*SIGUSR1: checkpoint written at \([0-9]*\) env steps.*/\1/p' "$cell0")
[ -n "$at" ] && [ "$at" -gt 0 ] && [ "$at" -lt 16000 ] || { cat "$cell0"; fail "no mid-run USR1 checkpoint in $cell0"; }
grep -q "=== attempt 2 .* train --out .*--resume" "$cell0" || { cat "$cell0"; fail "the requeued task did not resume"; }
grep -q -- "--threads 1 train" "$cell0" || fail "a task of --cpus-per-task 1 ran its run with other than 1 thread"
echo "task ${J1}_0: USR1 checkpoint at $at env steps, requeued, resumed"

phase "status after the cancel"
if "$EXE" sweep status "$T/slurm" >"$T/status1.out"; then cat "$T/status1.out"; fail "status exit 0 with a cancelled run"; fi
cat "$T/status1.out"
for k in 0 1 2; do grep -Eq "^${NAMES[$k]} +done " "$T/status1.out" || fail "${NAMES[$k]} is not done"; done
grep -Eq "^${NAMES[3]} +partial " "$T/status1.out" || fail "the cancelled run is not reported as partial"
tasklog=$(sed -n "s/^    slurm task ${J2}_0: //p" "$T/status1.out")
[ -n "$tasklog" ] && [ -f "$T/slurm/$tasklog" ] || fail "status does not name the cancelled run's Slurm task log"
grep -q "CANCELLED" "$T/slurm/$tasklog" || fail "$tasklog does not show the cancel"

phase "the same submit command again: only the unfinished run"
"${SUBMIT[@]}" >"$T/submit2.out" 2>&1 || { cat "$T/submit2.out"; fail "resubmit failed"; }
cat "$T/submit2.out"
mapfile -t IDS2 < <(grep -E '^[0-9]+$' "$T/submit2.out")
[ ${#IDS2[@]} = 1 ] || fail "the resubmission should be one job, got ${#IDS2[@]}"
grep -q "sweep: 1 runs in 1 tasks" "$T/submit2.out" || fail "the resubmission should hold 1 run"
tasks2=$(grep -l '"tasks":\[\[3\]\]' "$T"/slurm/slurm/submit-*/tasks.json) || fail "no tasks.json holding only cell 3"
sub2=$(dirname "$tasks2")
[ "$sub2" != "$sub1" ] || fail "the resubmission reused the first submission's directory"
wait_gone "${IDS2[0]}" 300
phase "resubmission done"
grep -q "=== attempt 2 .*--resume" "$T/slurm/logs/${NAMES[3]}.log" || fail "the cancelled run did not resume from its checkpoint"

"$EXE" sweep status "$T/slurm" >"$T/status2.out" || { cat "$T/status2.out"; fail "status exit != 0 when every run is done"; }
cat "$T/status2.out"
grep -q "total: 4 done" "$T/status2.out" || fail "status does not count 4 done"
"${SUBMIT[@]}" >"$T/submit3.out" 2>&1 || { cat "$T/submit3.out"; fail "the third submit failed"; }
grep -q "nothing to submit" "$T/submit3.out" || fail "a finished sweep submitted again: $(cat "$T/submit3.out")"
[ "$(grep -c job_id "$T/slurm/slurm/jobs.json")" = 3 ] || fail "jobs.json should list 3 jobs"

phase "compare with the local sweep"
python3 "$HERE/compare_runs.py" "$T/local" "$T/slurm"
for c in "${CELLS[@]}"; do
  for f in summary.json progress.csv policy_final.bin policy_best.bin; do
    [ -f "$T/slurm/runs/$c/$f" ] || fail "$c/$f is missing"
  done
done
phase "PASS ($(slurmctld -V))"
