"""ctest's entry to the Python suite: skips (exit 77) with a clear message when
NumPy, pytest or the built module are missing, else runs pytest on this folder.

    python3 python/tests/run_tests.py [pytest args]     (PYTHONPATH=build/python)
"""
import os
import sys

SKIP = 77


def main():
    missing = []
    for name, package in (("numpy", "python3-numpy"), ("pytest", "python3-pytest")):
        try:
            __import__(name)
        except ImportError:
            missing.append(f"{name} ({package})")
    if missing:
        print(f"python tests skipped: {', '.join(missing)} not importable by {sys.executable}")
        return SKIP
    try:
        import atacom  # noqa: F401
    except ImportError as e:
        print(f"python tests skipped: the atacom module is not importable ({e}); "
              f"build it and set PYTHONPATH=build/python")
        return SKIP
    import pytest

    here = os.path.dirname(os.path.abspath(__file__))
    return pytest.main(["-p", "no:cacheprovider", here] + sys.argv[1:])


if __name__ == "__main__":
    sys.exit(main())
