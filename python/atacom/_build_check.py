"""Why `import atacom` failed, in words: which Python the compiled module was built for.

CMake builds atacom._core for one interpreter (recorded at configure time in
_build_info.py beside this file). A different python3 (a pyenv or venv one
earlier on PATH, say) may lack NumPy or load the extension with another ABI.
"""
import os
import sys


def _built_for():
    try:
        from . import _build_info
    except ImportError:
        return None
    return _build_info


def _where():
    info = _built_for()
    here = f"this is {sys.executable} (Python {sys.version.split()[0]})"
    if info is None:
        return None, here
    return info, f"the module was built for {info.PYTHON_EXECUTABLE} (Python {info.PYTHON_VERSION}); {here}"


def _advice(info):
    if info is None:
        return ("Build it (cmake --build build --target atacom_python, then PYTHONPATH=build/python) or install it "
                "with `python3 -m pip install .`")
    if os.path.realpath(info.PYTHON_EXECUTABLE) != os.path.realpath(sys.executable):
        return (f"Run {info.PYTHON_EXECUTABLE}, or build for this interpreter: `{sys.executable} -m pip install .` "
                f"(or cmake -DPython_EXECUTABLE={sys.executable})")
    return "Rebuild the module (cmake --build build --target atacom_python)."


def check_numpy():
    """ImportError naming both interpreters when NumPy is missing."""
    try:
        import numpy  # noqa: F401
    except ImportError as e:
        info, where = _where()
        raise ImportError(f"atacom needs NumPy, which {sys.executable} cannot import ({e}); {where}. "
                          f"{_advice(info)}") from None


def import_error(e):
    """The ImportError to raise when atacom._core does not load."""
    info, where = _where()
    if info is None:
        return ImportError(f"atacom's compiled module _core is not in {os.path.dirname(os.path.abspath(__file__))} "
                           f"({e}); {where}. {_advice(info)}")
    return ImportError(f"atacom._core did not load ({e}); {where}. {_advice(info)}")
