"""ctest `python_pip`: the README's pip commands, offline, into a throwaway venv.

    python3 python/tests/pip_install_check.py SOURCE_DIR CMAKE_BUILD_DIR

Makes a venv with --system-site-packages (Debian's NumPy, setuptools and
wheel visible, as the README's command), runs `pip install --no-index
SOURCE_DIR` there (--no-index: any attempt to download fails the test instead
of reaching PyPI), imports the installed module from outside the source tree
and steps an env, checks `pip show`, makes a wheel with `pip wheel --no-deps
--no-build-isolation`, and uninstalls. ATACOM_PIP_BUILD_DIR=CMAKE_BUILD_DIR
reuses the extension this build already compiled (setup.py only runs the
module target there, a no-op when it is up to date), so the test takes
seconds, not a full compile. Exits 77 (skipped) without the venv module.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile

SKIP = 77


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, **kw)
    if r.returncode != 0:
        sys.stderr.write(f"FAILED ({r.returncode}): {' '.join(cmd)}\n{r.stdout}\n{r.stderr}\n")
        sys.exit(1)
    return r.stdout


def main():
    src, build = (os.path.abspath(a) for a in sys.argv[1:3])
    try:
        import ensurepip  # noqa: F401  (Debian: python3-venv)
        import venv  # noqa: F401
    except ImportError as e:
        print(f"pip install test skipped: {sys.executable} has no venv/ensurepip ({e}; Debian: python3-venv)")
        return SKIP
    version = re.search(r"project\(atacom VERSION (\S+)", open(os.path.join(src, "CMakeLists.txt")).read()).group(1)
    tmp = tempfile.mkdtemp(prefix="atacom-pip-")
    try:
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ATACOM_DATA_DIR", "PIP_INDEX_URL")}
        env.update(ATACOM_PIP_BUILD_DIR=build, PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONDONTWRITEBYTECODE="1")
        venv_dir = os.path.join(tmp, "venv")
        run([sys.executable, "-m", "venv", "--system-site-packages", venv_dir], env=env)
        py = os.path.join(venv_dir, "bin", "python")
        run([py, "-m", "pip", "install", "--no-index", src], env=env, cwd=tmp)

        probe = ("import atacom, numpy as np\n"
                 "env = atacom.make_vec('table', 2, seed=1)\n"
                 "obs, info = env.reset()\n"
                 "obs, r, te, tr, info = env.step(np.zeros((2, env.act_dim)))\n"
                 "assert obs.shape == (2, env.obs_dim) and info['constraints'].shape == (2, 34)\n"
                 "print(atacom.__file__)\n")
        where = run([py, "-c", probe], env=env, cwd=tmp).strip()
        assert where.startswith(venv_dir), f"imported {where}, not the venv's install"
        assert os.path.isdir(os.path.join(os.path.dirname(where), "data")), "data/ was not installed"

        show = run([py, "-m", "pip", "show", "-f", "atacom"], env=env, cwd=tmp)
        assert f"Version: {version}" in show, show
        assert re.search(r"atacom/_core\..*\.so", show), "pip show -f lists no compiled module:\n" + show

        wheels = os.path.join(tmp, "wheels")
        run([py, "-m", "pip", "wheel", "--no-index", "--no-deps", "--no-build-isolation", "-w", wheels, src],
            env=env, cwd=tmp)
        (whl,) = os.listdir(wheels)
        assert whl.startswith(f"atacom-{version}-") and whl.endswith(".whl"), whl
        names = zipfile.ZipFile(os.path.join(wheels, whl)).namelist()
        for needed in ("atacom/__init__.py", "atacom/_build_info.py", "atacom/data/tiago_arm.json"):
            assert needed in names, f"{whl} lacks {needed}"
        assert any(re.match(r"atacom/_core\..*\.so$", n) for n in names), f"{whl} has no compiled module"

        run([py, "-m", "pip", "uninstall", "-y", "atacom"], env=env, cwd=tmp)
        gone = subprocess.run([py, "-c", "import atacom"], capture_output=True, text=True, env=env, cwd=tmp)
        assert gone.returncode != 0, "atacom still importable after pip uninstall"
        print(f"pip install, show, wheel ({whl}), uninstall: ok")
        return 0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
