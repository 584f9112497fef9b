#!/usr/bin/env bash
# Manual (not in ctest: it takes minutes): the real pre-timeout path. One run longer
# than the task's time limit (--time 2, --presignal 30): Slurm itself sends USR1
# (--signal=B:USR1@30) before the limit, the run checkpoints, the task requeues
# itself, as often as it takes; the result must equal the same run done locally.
#   timelimit_requeue.sh ATACOM_EXE [STEPS]
set -euo pipefail
export PATH=$PATH:/usr/sbin:/sbin
EXE=$(realpath "${1:?usage: timelimit_requeue.sh ATACOM_EXE [STEPS]}")
STEPS=${2:-250000}
HERE=$(cd "$(dirname "$0")" && pwd)
T=$(mktemp -d /tmp/atacom-slurm-limit.XXXXXX); chmod 755 "$T"
export SLURM_CONF=$T/cluster/slurm.conf
trap 'bash "$HERE/cluster.sh" down "$T/cluster"; [ "${ATACOM_KEEP_SLURM_TEST:-0}" = 1 ] || rm -rf "$T"' EXIT
cat > "$T/spec.json" <<JSON
{"envs": ["table"], "algos": ["atacom-sac"], "seeds": [0], "steps": $STEPS, "num_envs": 4,
 "overrides": {"*/*": {"train": {"eval_every": 5000, "eval_episodes": 2},
   "sac": {"initial_replay": 400, "warmup": 400, "batch_size": 32,
           "actor": {"hidden": [64, 64]}, "critic": {"hidden": [64, 64]}}}}}
JSON
bash "$HERE/cluster.sh" up "$T/cluster"
s0=$(date +%s)
id=$("$EXE" sweep "$T/spec.json" --out "$T/slurm" --slurm --time 2 --presignal 30 | tail -1)
echo "job $id submitted"
while :; do
  rc=0; out=$(squeue -h -j "$id" -o '%i %t %M' 2>&1) || rc=$?
  [ $rc = 0 ] && [ -z "$out" ] && break
  sleep 1
done
s1=$(date +%s)
echo "slurm: done in $((s1 - s0)) s, restarts: $(scontrol show job -o "${id}_0" | tr ' ' '\n' | sed -n 's/^Restarts=//p')"
grep -h "^===\|SIGUSR1" "$T"/slurm/slurm/submit-*/task-*.log "$T"/slurm/logs/*.log | cut -c1-160
"$EXE" sweep "$T/spec.json" --out "$T/local" 2>/dev/null
echo "local: $(( $(date +%s) - s1 )) s"
python3 "$HERE/compare_runs.py" "$T/local" "$T/slurm" --except-host  # local: 2 threads, the task: 1
"$EXE" sweep status "$T/slurm"
echo "ok"
