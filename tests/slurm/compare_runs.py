#!/usr/bin/env python3
"""compare_runs.py A B: every file under A/runs equals the one under B/runs.

The wall-clock fields are the only thing allowed to differ between two sweeps
of the same spec (docs/sweeps.md): wall_s in summary.json and checkpoint.json,
the wall_s column of progress.csv, and checkpoint.bin (its counters hold the
wall time; checkpoint.json holds its agent hash). Everything else, policies
included, must be the same bytes. Exit 0 when equal, 1 with the differences.
"""
import json
import os
import sys


def comparable(path):
    name = os.path.basename(path)
    with open(path, "rb") as f:
        data = f.read()
    if name in ("summary.json", "checkpoint.json"):
        j = json.loads(data)
        j.pop("wall_s", None)
        return json.dumps(j, sort_keys=True).encode()
    if name == "progress.csv":
        rows = [line.split(",") for line in data.decode().splitlines()]
        if not rows or len(rows[0]) < 3 or rows[0][2] != "wall_s":
            raise SystemExit(f"{path}: the third column is not wall_s")
        return "\n".join(",".join(r[:2] + r[3:]) for r in rows).encode()
    return data


def files(root):
    out = {}
    for d, _, names in os.walk(os.path.join(root, "runs")):
        for n in names:
            if n != "checkpoint.bin":
                p = os.path.join(d, n)
                out[os.path.relpath(p, root)] = p
    return out


def main():
    a, b = files(sys.argv[1]), files(sys.argv[2])
    bad = [f"only in {sys.argv[1]}: {k}" for k in sorted(a.keys() - b.keys())]
    bad += [f"only in {sys.argv[2]}: {k}" for k in sorted(b.keys() - a.keys())]
    same = 0
    for k in sorted(a.keys() & b.keys()):
        if comparable(a[k]) == comparable(b[k]):
            same += 1
        else:
            bad.append(f"differs: {k}")
    for line in bad:
        print("compare_runs:", line)
    print(f"compare_runs: {same} files equal, {len(bad)} differences")
    return 1 if bad or same == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
