#!/usr/bin/env python3
"""Do two run directories hold the same run, wall times aside?

Compares progress.csv row by row and summary.json key by key, leaving out
only the wall-clock fields (docs/sweeps.md, "The sweep directory": wall_s,
time_to_target_s, eval_wall_s, eval_share) and the machine's name (host). The reference's columns and keys
are what must agree: a retrained run may add keys a newer build writes (runs
made before issue 32 lack eval_cost_mean and train_cost). Exits 0 when every
pair agrees, 1 otherwise. docs/sweeps.md ("When the machine is replaced")
uses it to check shelf policies retrained from their committed configs.

    python3 python/examples/same_run.py RETRAINED_DIR REFERENCE_DIR
    python3 python/examples/same_run.py RETRAINED_PARENT REFERENCE_PARENT --seeds 0-16
"""
import argparse
import csv
import json
import os
import sys

WALL = {"wall_s", "time_to_target_s", "eval_wall_s", "eval_share"}


def differences(new, ref, path=""):
    """Keys of ref (nested) whose value new lacks or differs in, wall fields aside."""
    out = []
    for k, v in ref.items():
        if k in WALL or k == "host":
            continue
        if k not in new:
            out.append(path + k + " missing")
        elif isinstance(v, dict) and isinstance(new[k], dict):
            out += differences(new[k], v, path + k + ".")
        elif new[k] != v:
            out.append(f"{path}{k}: {new[k]!r} vs {v!r}")
    return out


def compare(new_dir, ref_dir):
    """The first differences between two run directories (empty: the same run)."""
    rows = [list(csv.DictReader(open(os.path.join(d, "progress.csv")))) for d in (new_dir, ref_dir)]
    if len(rows[0]) != len(rows[1]):
        return [f"progress.csv: {len(rows[0])} rows vs {len(rows[1])}"]
    for i, (a, b) in enumerate(zip(*rows)):
        d = differences(a, b)
        if d:
            return [f"progress.csv row {i + 1}: " + x for x in d[:3]]
    summaries = [json.load(open(os.path.join(d, "summary.json"))) for d in (new_dir, ref_dir)]
    return ["summary.json " + x for x in differences(*summaries)[:3]]


def seed_list(text):
    lo, _, hi = text.partition("-")
    return range(int(lo), int(hi or lo) + 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("new")
    ap.add_argument("reference")
    ap.add_argument("--seeds", help="compare NEW/seed-S with REFERENCE/seed-S for S in this range, e.g. 0-16")
    args = ap.parse_args()
    pairs = [(args.new, args.reference)] if not args.seeds else [
        (os.path.join(args.new, f"seed-{s}"), os.path.join(args.reference, f"seed-{s}")) for s in seed_list(args.seeds)]
    same = 0
    for new, ref in pairs:
        d = compare(new, ref)
        print(f"{new}: " + ("same run" if not d else "DIFFERENT: " + "; ".join(d)))
        same += not d
    print(f"{same} of {len(pairs)} the same")
    sys.exit(0 if same == len(pairs) else 1)


if __name__ == "__main__":
    main()
