#!/usr/bin/env python3
"""Every test file compiles beside every other (the unity build's premise):
all tests/test_*.cpp #included into one translation unit, syntax-checked with
the flags of the build's first unity batch. Usage, after a configure of BUILD:
    python3 tests/check_tests_compile_together.py BUILD
Prints the error count (0 is a pass) and the first errors; about a minute."""
import glob, json, os, shlex, subprocess, sys, tempfile

build = sys.argv[1] if len(sys.argv) > 1 else "build"
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
entries = json.load(open(os.path.join(build, "compile_commands.json")))
batch = next(e for e in entries if "unity_0_cxx" in e["file"])
with tempfile.NamedTemporaryFile("w", suffix=".cpp", delete=False) as f:
    f.write('#define ATACOM_TEST_DATA_DIR "unused"\n#define ATACOM_README_PATH "unused"\n')
    for src in sorted(glob.glob(os.path.join(root, "tests", "test_*.cpp"))):
        f.write('#include "%s"\n' % src)
args = shlex.split(batch["command"])
del args[args.index("-o"):args.index("-o") + 2]
args[-1] = f.name
r = subprocess.run(args + ["-fsyntax-only", "-fmax-errors=0"], cwd=batch["directory"], capture_output=True, text=True)
os.unlink(f.name)
errors = [l for l in r.stderr.splitlines() if "error:" in l]
print("%d errors" % len(errors))
print("\n".join(errors[:20]))
sys.exit(1 if errors else 0)
