"""Shared fixtures: the atacom executable (for the CLI-agreement tests)."""
import os
import subprocess

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))


def atacom_exe():
    exe = os.environ.get("ATACOM_EXE") or os.path.join(REPO, "build", "atacom")
    return exe if os.path.isfile(exe) and os.access(exe, os.X_OK) else None


@pytest.fixture(scope="session")
def cli():
    """Runs `atacom <args>` and returns its stdout; skips when the executable is missing."""
    exe = atacom_exe()
    if exe is None:
        pytest.skip("the atacom executable was not found (set ATACOM_EXE)")

    def run(args, stdin=None):
        r = subprocess.run([exe] + list(args), input=stdin, capture_output=True, text=True, timeout=120)
        return r.returncode, r.stdout, r.stderr

    return run
