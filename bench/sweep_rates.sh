#!/usr/bin/env bash
# The measured rates behind `atacom sweep --dry-run`'s cost estimate:
#   bench/sweep_rates.sh [ATACOM_BINARY] > data/sweep_rates.json
# writes the table with this command, the CPU and the date. Per env and
# safety layer, SAC with the env's default settings, one thread (a sweep's
# default on 2 cores: one run per core), 4 training envs as every shipped
# sweep spec. Rates are env steps per CPU second of the run's process (user +
# system), which a loaded machine inflates far less than wall time:
#   collect_per_s  the steps before the first update (sac.initial_replay = 5000:
#                  acting and storing only): a 5000-step run
#   train_per_s    the steps with updates: (10000 - 6000) / (cpu(10000-step run) - cpu(6000))
#   eval_per_s     evaluation env steps with the SAC policy (all episodes of an
#                  evaluation step together): the 6000-step run again with an
#                  evaluation of 5 episodes every 100 steps, (its CPU - cpu(6000))
#                  / the evaluation steps its progress.csv adds up to
# About 6 CPU minutes on an idle core (13 env/layer pairs x 4 runs).
set -euo pipefail
atacom=${1:-build/atacom}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo '{"train": {"eval_every": 1000000}}' > "$tmp/one_eval.json"
echo '{"train": {"eval_every": 100}}' > "$tmp/many_evals.json"
cpu_of() {  # the CPU seconds of a command (its process and children)
  python3 - "$@" <<'PY'
import resource, subprocess, sys
subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
r = resource.getrusage(resource.RUSAGE_CHILDREN)
print(r.ru_utime + r.ru_stime)
PY
}
run() {  # env algo steps eval_episodes config -> cpu seconds; the run directory is $tmp/<env>-<algo>-<steps>-<episodes>
  cpu_of "$atacom" --threads 1 train --env "$1" --algo "$2" --steps "$3" --envs 4 --eval-episodes "$4" \
    --config "$tmp/$5.json" --out "$tmp/$1-$2-$3-$4"
}
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
echo "{"
echo "  \"command\": \"bench/sweep_rates.sh build/atacom > data/sweep_rates.json\","
echo "  \"cpu\": \"$cpu\","
echo "  \"date\": \"$(date -u +%Y-%m-%d)\","
echo "  \"unit\": \"env steps per CPU second, one thread per run, train.num_envs 4, each env's default SAC settings\","
echo "  \"rates\": ["
first=1
envs=$("$atacom" train --help | sed -n 's/.*env: \([a-z, ]*\) (train.env).*/\1/p' | tr -d ',')
for env in $envs; do
  layers="none atacom safelayer"
  [ "$env" = pendulum ] && layers="none"
  for layer in $layers; do
    case $layer in none) sac=sac ;; atacom) sac=atacom-sac ;; *) sac=safelayer-sac ;; esac
    c5=$(run "$env" "$sac" 5000 1 one_eval)
    c6=$(run "$env" "$sac" 6000 1 one_eval)
    c10=$(run "$env" "$sac" 10000 1 one_eval)
    c6e=$(run "$env" "$sac" 6000 5 many_evals)
    eval_steps=$(python3 - "$tmp/$env-$sac-6000-5/progress.csv" "$tmp/$env-$sac-6000-1/progress.csv" <<'PY'
import csv, sys
def steps(path, episodes):
    return sum(episodes * float(r["avg_episode_steps"]) for r in csv.DictReader(open(path)))
print(steps(sys.argv[1], 5) - steps(sys.argv[2], 1))
PY
)
    rates=$(python3 -c "print('%.0f %.0f %.0f' % (5000 / $c5, 4000 / max(1e-9, $c10 - $c6), $eval_steps / max(1e-9, $c6e - $c6)))")
    read -r collect train ev <<< "$rates"
    [ $first = 1 ] || echo ","
    first=0
    printf '    {"env": "%s", "safety": "%s", "collect_per_s": %s, "train_per_s": %s, "eval_per_s": %s}' \
      "$env" "$layer" "$collect" "$train" "$ev"
  done
done
echo ""
echo "  ]"
echo "}"
