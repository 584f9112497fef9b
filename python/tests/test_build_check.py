"""`import atacom` from a python3 that cannot use the built module says which python it was built for."""
import os
import subprocess
import sys

import atacom


def test_a_python_without_numpy_is_told_which_python_to_use():
    # -S: no site-packages, so this same interpreter cannot import NumPy (as a pyenv python without it).
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(atacom.__file__)))
    code = f"import sys; sys.path.insert(0, {package_parent!r}); import atacom"
    r = subprocess.run([sys.executable, "-S", "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode != 0
    from atacom import _build_info

    assert "atacom needs NumPy" in r.stderr, r.stderr
    assert f"built for {_build_info.PYTHON_EXECUTABLE}" in r.stderr, r.stderr
    assert sys.executable in r.stderr, r.stderr


def test_build_info_names_an_interpreter_of_this_abi():
    from atacom import _build_info

    assert os.path.isfile(_build_info.PYTHON_EXECUTABLE)
    assert _build_info.PYTHON_VERSION.split(".")[:2] == [str(v) for v in sys.version_info[:2]]
