#!/usr/bin/env bash
# Runs every benchmark and keeps the JSON lines per machine:
#   bench/results/<host>-<date>.jsonl
# Usage: bench/run_all.sh [build-dir]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
mkdir -p bench/results
out="bench/results/$(hostname -s)-$(date +%Y%m%d-%H%M).jsonl"
for b in "$build"/bench/bench_*; do
  [ -x "$b" ] || continue
  echo "running $(basename "$b")" >&2
  "$b" | tee -a "$out"
done
echo "wrote $out" >&2
