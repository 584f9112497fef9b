#!/usr/bin/env bash
# One command on a fresh Debian machine: install what is missing (apt, when
# root; otherwise print the exact apt line), configure, build, and run the
# main job on its built-in default.
set -euo pipefail
cd "$(dirname "$0")"

# The last four build and test the Python module (python/); python3-torch is
# optional (only python/examples/sac_torch.py uses it) and not installed here.
PACKAGES=(build-essential cmake libeigen3-dev libtbb-dev libbox2d-dev nlohmann-json3-dev catch2 libcli11-dev
          pybind11-dev python3-dev python3-numpy python3-pytest)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -eq 0 ]; then
    echo "setup: installing ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
  else
    echo "setup: missing Debian packages. Run this, then ./setup.sh again:"
    echo "  sudo apt-get install -y ${missing[*]}"
    exit 1
  fi
fi

jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$jobs"

# The main job on its built-in default: ATACOM-SAC on TableEnv (TIAGo arm
# reaching above a table under 34 constraints), 20k env steps, 4 envs,
# about 20 s on 2 cores. Each run gets its own directory; nothing is overwritten.
run="runs/table-atacom-sac-$(date +%Y%m%d-%H%M%S)"
./build/atacom train --env table --algo atacom-sac --seed 0 --steps 20000 --envs 4 --out "$run" > /dev/null
echo "setup: main job done; results in $run (summary.json, progress.csv, progress.svg)"
grep -o '"\(eval_return_mean\|final_distance\|early_terminations\|train_collisions\|train_violations\)":[^,}]*' \
  "$run/summary.json" | tr '\n' ' '
echo
