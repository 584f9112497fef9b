#!/usr/bin/env python3
"""compare_runs.py A B [--except-host]: every file under A/runs equals the one under B/runs.

The wall-clock fields are the only thing allowed to differ between two sweeps
of the same spec (docs/sweeps.md): wall_s in summary.json and checkpoint.json,
time_to_target_s, eval_wall_s and eval_share in summary.json, the wall_s and
time_to_target_s columns of progress.csv, and checkpoint.bin (its counters hold the
wall time; checkpoint.json holds its agent hash). Everything else, policies
included, must be the same bytes. --except-host also sets aside the "host"
record of config.json and summary.json (where and how a run ran: hostname,
CPU, threads), for runs done on other machines or with other thread counts;
its differences are printed. Exit 0 when equal, 1 with the differences.
"""
import json
import os
import sys


EXCEPT_HOST = "--except-host" in sys.argv[3:]


def comparable(path):
    name = os.path.basename(path)
    with open(path, "rb") as f:
        data = f.read()
    if name in ("summary.json", "checkpoint.json"):
        j = json.loads(data)
        for k in ("wall_s", "time_to_target_s", "eval_wall_s", "eval_share"):
            j.pop(k, None)
        if EXCEPT_HOST and name == "summary.json":
            j.pop("host", None)
        return json.dumps(j, sort_keys=True).encode()
    if name == "config.json" and EXCEPT_HOST:
        j = json.loads(data)
        j.pop("host", None)
        return json.dumps(j, sort_keys=True).encode()
    if name == "progress.csv":
        rows = [line.split(",") for line in data.decode().splitlines()]
        if not rows or len(rows[0]) < 3 or rows[0][2] != "wall_s":
            raise SystemExit(f"{path}: the third column is not wall_s")
        wall = {k for k, c in enumerate(rows[0]) if c in ("wall_s", "time_to_target_s")}
        return "\n".join(",".join(c for k, c in enumerate(r) if k not in wall) for r in rows).encode()
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
            if EXCEPT_HOST and k.endswith(("summary.json", "config.json")):
                ha, hb = (json.load(open(p)).get("host", {}) for p in (a[k], b[k]))
                diff = sorted(x for x in ha.keys() | hb.keys() if ha.get(x) != hb.get(x))
                if diff:
                    print(f"compare_runs: {k}: host differs (set aside): " +
                          ", ".join(f"{x} {ha.get(x)} / {hb.get(x)}" for x in diff))
        else:
            bad.append(f"differs: {k}")
    for line in bad:
        print("compare_runs:", line)
    print(f"compare_runs: {same} files equal, {len(bad)} differences")
    return 1 if bad or same == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
