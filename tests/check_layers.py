#!/usr/bin/env python3
"""The include graph against the layers of ARCHITECTURE.md: a layer includes only layers below it.

Walks every #include "..." of the library, the front ends and the generated headers' users, maps the
including file and the included header to a layer, and fails (exit 1, one line per edge) on any edge
that goes up. Also fails on a source file over 700 lines and on a public header with no layer in
PUBLIC_HEADERS (a new one must say which layer it belongs to). Benches, tests and examples may
include anything and are not checked.

usage: check_layers.py <source root>
"""
import os
import re
import sys

LAYERS = ["core", "kernels", "envs", "safety", "learning", "experiments", "front end"]

# Folder prefix -> layer, longest prefix first when matching.
DIR_LAYER = {
    "src/core/": "core",
    "kernels/": "kernels",
    "envs/": "envs",
    "src/safety/": "safety",
    "train/": "learning",
    "src/experiments/": "experiments",
    "src/experiments/": "experiments",
    "src/experiments/": "experiments",
    "src/cli/": "front end",
    "python/src/": "front end",
}

# include/atacom/<name>.hpp is one layer's interface: the layer of the code that implements it.
PUBLIC_HEADERS = {
    "control_affine_env": "core",  # the env contract's control-affine form: envs implement it, safety reads it
    "data_dir": "core",
    "env": "core",
    "parallel": "core",
    "policy": "core",  # the policy contract: envs' hand-coded controllers implement it
    "projector": "core",
    "rng": "core",
    "system": "core",
    "safelayer": "kernels",
    "env_registry": "envs",
    "layered_env": "safety",
    "make_env": "safety",
    "safe_env": "safety",
    "safety_layer": "safety",
    "evaluate": "learning",
    "learner": "learning",
    "trainer": "learning",
}

# Extra "never" rules of the table beyond the order: front ends never include each other, and the
# safety layer reads envs only through their public contract (never an envs/ header).
FORBIDDEN = [
    ("src/cli/", "python/src/"),
    ("python/src/", "src/cli/"),
    ("src/safety/", "envs/"),
]

# Written by CMake into the build tree: the presets (configs/presets/*.json) for train/presets.cpp, the
# compiler flags and the git revision for src/core/host_info.cpp.
GENERATED = {"atacom_presets.hpp": "learning", "atacom_build_flags.hpp": "core", "atacom_git.hpp": "core"}
MAX_LINES = 700
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def layer_of_path(rel):
    for prefix in sorted(DIR_LAYER, key=len, reverse=True):
        if rel.startswith(prefix):
            return DIR_LAYER[prefix]
    return None


def resolve(root, includer, target):
    """The include's path relative to root, as the build's include directories resolve it."""
    if target.startswith("atacom/"):
        return "include/" + target
    if target in GENERATED:
        return target
    local = os.path.normpath(os.path.join(os.path.dirname(includer), target))
    if os.path.exists(os.path.join(root, local)):
        return local
    for base in ("", "src/"):  # the build's include roots: the source root and src/
        if os.path.exists(os.path.join(root, base + target)):
            return base + target
    return None


def layer_of_target(rel):
    if rel in GENERATED:
        return GENERATED[rel]
    if rel.startswith("include/atacom/"):
        name = os.path.splitext(os.path.basename(rel))[0]
        return PUBLIC_HEADERS.get(name, "unmapped")
    return layer_of_path(rel)


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    problems = []
    edges = 0
    for top in ("src", "kernels", "envs", "train", "include", "python/src"):
        for dirpath, _, files in os.walk(os.path.join(root, top)):
            for name in sorted(files):
                if not name.endswith((".hpp", ".cpp", ".h")):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                with open(path, encoding="utf-8") as f:
                    lines = f.readlines()
                if len(lines) > MAX_LINES:
                    problems.append(f"{rel}: {len(lines)} lines (at most {MAX_LINES})")
                if rel.startswith("include/atacom/"):
                    own = layer_of_target(rel)
                    if own == "unmapped":
                        problems.append(f"{rel}: public header without a layer (add it to PUBLIC_HEADERS)")
                        continue
                else:
                    own = layer_of_path(rel)
                if own is None:
                    continue
                for number, line in enumerate(lines, 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    target = resolve(root, rel, m.group(1))
                    if target is None:
                        problems.append(f"{rel}:{number}: cannot resolve \"{m.group(1)}\"")
                        continue
                    edges += 1
                    for src_prefix, dst_prefix in FORBIDDEN:
                        if rel.startswith(src_prefix) and target.startswith(dst_prefix):
                            problems.append(f"{rel}:{number}: {src_prefix} never includes {dst_prefix} ({target})")
                    their = layer_of_target(target)
                    if their in (None, "unmapped"):
                        continue
                    if LAYERS.index(their) > LAYERS.index(own):
                        problems.append(f"{rel}:{number}: {own} includes {their} ({target})")
    for p in problems:
        print(p)
    print(f"{edges} include edges checked, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
