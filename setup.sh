#!/usr/bin/env bash
# One command on a fresh Debian machine: install what is missing (apt, when
# root; otherwise print the exact apt line), configure, build, and run the
# main job on its built-in default.
set -euo pipefail
cd "$(dirname "$0")"

# pybind11-dev .. python3-pytest build and test the Python module (python/);
# python3-pip, python3-setuptools, python3-wheel and python3-venv are what
# `pip install .` uses offline (setup.py drives CMake; the README's venv
# command; ctest's python_pip test runs it). python3-torch is optional (only
# python/examples/sac_torch.py uses it) and not installed here.
PACKAGES=(build-essential cmake libeigen3-dev libtbb-dev libbox2d-dev nlohmann-json3-dev catch2 libcli11-dev
          pybind11-dev python3-dev python3-numpy python3-pytest
          python3-pip python3-setuptools python3-wheel python3-venv)
# (`./setup.sh --packages` prints the list, for CI's single apt transaction.)
if [ "${1:-}" = "--packages" ]; then echo "${PACKAGES[*]}"; exit 0; fi
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

# The main job: a small sweep and its report (configs/sweeps/readme.json):
# ATACOM-SAC and SAC on TableEnv (TIAGo arm reaching above a table under 34
# constraints), one seed, 20k env steps with 4 envs each, an evaluation every
# 1000 steps; about a minute on 2 cores. Each sweep gets its own directory;
# nothing is overwritten.
sweep="runs/main-$(date +%Y%m%d-%H%M%S)"
./build/atacom sweep configs/sweeps/readme.json --out "$sweep"
./build/atacom report "$sweep" > /dev/null
echo "setup: main job done; report: $PWD/$sweep/report/index.html"
# The two runs side by side (from report/summary.csv; one seed, so the IQM is the value).
awk -F, 'NR > 1 && $1 == "table" { v[$2, $3] = $10 }
  END {
    printf "%-11s %17s %19s %19s\n", "algo", "train collisions", "early terminations", "final distance [m]"
    n = split("atacom-sac sac", a, " ")
    for (i = 1; i <= n; ++i)
      printf "%-11s %17g %19g %19.3f\n", a[i], v[a[i], "train_collisions"], v[a[i], "train_terminations"], v[a[i], "final_distance"]
  }' "$sweep/report/summary.csv"
cat <<'EOF'
One seed per algorithm (n = 1): the table says what happened in these two runs
(whether training touched the table, how close the final policy got), not how
often it would happen again, nor whether the distance gap is larger than the
spread between seeds; the report gives no interval or P(improvement) from one
seed. With 3 seeds: ./build/atacom sweep configs/sweeps/quick.json --out DIR
EOF
