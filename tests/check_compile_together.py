#!/usr/bin/env python3
"""Every file of a unity-built target compiles beside every other (the unity
build's premise, so any batching works): the library's sources (src, kernels,
envs, train), the subcommands (src/cli) and the tests (tests/test_*.cpp) each #included
into one translation unit and syntax-checked with the flags of that target's
first unity batch. Files the build compiles alone (their own options or
definitions) are left out. Usage, after a configure of BUILD:
    python3 tests/check_compile_together.py BUILD
Prints each target's error count (0 is a pass) and the first errors; about
two minutes."""
import glob, json, os, shlex, subprocess, sys, tempfile

build = sys.argv[1] if len(sys.argv) > 1 else "build"
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
entries = json.load(open(os.path.join(build, "compile_commands.json")))
alone = {os.path.realpath(e["file"]) for e in entries if "/Unity/" not in e["file"]}


def check(target, sources):
    batch = next(e for e in entries if "%s.dir/Unity/unity_0_cxx" % target in e["file"])
    with tempfile.NamedTemporaryFile("w", suffix=".cpp", delete=False) as f:
        for src in sorted(sources):
            if os.path.realpath(src) not in alone:
                f.write('#include "%s"\n' % src)
    args = shlex.split(batch["command"])
    del args[args.index("-o"):args.index("-o") + 2]
    args[-1] = f.name
    r = subprocess.run(args + ["-fsyntax-only", "-fmax-errors=0"], cwd=batch["directory"], capture_output=True,
                       text=True)
    os.unlink(f.name)
    errors = [l for l in r.stderr.splitlines() if "error:" in l]
    print("%s: %d errors" % (target, len(errors)))
    if errors:
        print("\n".join(errors[:20]))
    return len(errors)


lib = [p for d in ("src", "kernels", "envs", "train")
       for p in glob.glob(os.path.join(root, d, "**", "*.cpp"), recursive=True) if "/src/cli/" not in p]
cli = glob.glob(os.path.join(root, "src", "cli", "*.cpp"))
tests = glob.glob(os.path.join(root, "tests", "test_*.cpp"))
failed = check("atacom_lib", lib)
failed += check("atacom", cli)
failed += check("atacom_tests", tests)
sys.exit(1 if failed else 0)
