"""pip install . : the Python module `atacom`, built by CMake, packaged by setuptools.

Debian 12 (offline, Debian's own toolchain; README "Python" has the why):

    python3 -m venv --system-site-packages ~/.venvs/atacom    # sees Debian's NumPy
    ~/.venvs/atacom/bin/python -m pip install .
    ~/.venvs/atacom/bin/python -c "import atacom; print(atacom.env_names())"

There is deliberately no pyproject.toml: with one, pip builds in an isolated
environment and downloads setuptools from PyPI first; without one, pip uses
the setuptools and wheel already installed (python3-setuptools, python3-wheel),
so the build needs no network. `python3 -m pip wheel . --no-deps
--no-build-isolation` makes a wheel the same way.

The extension is compiled for the Python running pip (sys.executable), in a
CMake build directory that is kept between installs (incremental; ccache is
used when it is on PATH):
  ATACOM_PIP_BUILD_DIR  the CMake build directory (default build-pip-<python tag>;
                        an existing configured build of this tree, e.g. build,
                        is reused as it is: only the module target is built)
  ATACOM_CMAKE_ARGS     extra configure arguments, e.g. "-DATACOM_NATIVE=OFF"
                        for a wheel that runs on CPUs other than this one
  ATACOM_BUILD_JOBS     parallel compile jobs (default: the CPU count)
"""
import os
import shlex
import shutil
import subprocess
import sys
import sysconfig

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))


def project_version():
    """The version of CMakeLists.txt's project() line (one source of truth)."""
    with open(os.path.join(HERE, "CMakeLists.txt"), encoding="utf-8") as f:
        for line in f:
            if line.startswith("project(atacom VERSION "):
                return line.split()[2]
    raise RuntimeError("CMakeLists.txt: no 'project(atacom VERSION x.y.z ...)' line")


def cmake_build_dir():
    tag = f"{sys.implementation.cache_tag}-{sysconfig.get_platform()}"
    # Beside build/, at the same depth: ccache (base_dir relative paths) then shares the objects of
    # a ./setup.sh build, and a first pip install compiles little.
    return os.path.abspath(os.environ.get("ATACOM_PIP_BUILD_DIR") or os.path.join(HERE, f"build-pip-{tag}"))


class CMakeExtension(Extension):
    """atacom._core, compiled by CMake's target atacom_python (python/CMakeLists.txt)."""

    def __init__(self):
        super().__init__("atacom._core", sources=[])


class BuildWithCMake(build_ext):
    """Configure (once) and build the module target, then copy the package CMake laid out."""

    def run(self):
        build = cmake_build_dir()
        cmake = shutil.which("cmake")
        if cmake is None:
            raise RuntimeError("atacom: cmake is not on PATH (Debian: apt-get install cmake)")
        cache = os.path.join(build, "CMakeCache.txt")
        if not os.path.isfile(cache):
            args = [cmake, "-S", HERE, "-B", build, "-DCMAKE_BUILD_TYPE=Release", "-DATACOM_PYTHON=ON",
                    f"-DPython_EXECUTABLE={sys.executable}", "-DATACOM_BUILD_TESTS=OFF",
                    "-DATACOM_BUILD_BENCH=OFF"]
            if shutil.which("ccache"):
                args.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
            args += shlex.split(os.environ.get("ATACOM_CMAKE_ARGS", ""))
            self.announce("atacom: " + " ".join(args), level=2)
            subprocess.check_call(args)
        else:
            self.check_reused_build(cache)
        jobs = os.environ.get("ATACOM_BUILD_JOBS") or str(os.cpu_count() or 2)
        subprocess.check_call([cmake, "--build", build, "--target", "atacom_python", "-j", jobs])

        package = os.path.join(build, "python", "atacom")
        out = os.path.join(os.path.abspath(self.build_lib), "atacom")
        os.makedirs(out, exist_ok=True)
        for name in os.listdir(package):
            src, dst = os.path.join(package, name), os.path.join(out, name)
            if name == "__pycache__":
                continue
            if os.path.isdir(src):
                shutil.rmtree(dst, ignore_errors=True)
                shutil.copytree(src, dst, ignore=shutil.ignore_patterns("__pycache__"))
            else:
                shutil.copy2(src, dst)

    def check_reused_build(self, cache):
        """A kept build directory must build for this interpreter, or the module would not import."""
        with open(cache, encoding="utf-8", errors="replace") as f:
            entries = dict(line.rstrip("\n").split("=", 1) for line in f
                           if "=" in line and not line.startswith(("#", "//")))
        exe = next((v for k, v in entries.items() if k.split(":")[0] == "Python_EXECUTABLE"), "")
        if exe and os.path.realpath(exe) != os.path.realpath(sys.executable):
            same = subprocess.run([exe, "-c", "import sys; print(sys.implementation.cache_tag)"],
                                  capture_output=True, text=True).stdout.strip()
            if same != sys.implementation.cache_tag:
                raise RuntimeError(f"atacom: the CMake build {os.path.dirname(cache)} builds for {exe} "
                                   f"({same or 'unknown'}), pip runs {sys.executable} "
                                   f"({sys.implementation.cache_tag}); unset ATACOM_PIP_BUILD_DIR or point it "
                                   f"at a build for this Python")


class BuildPy(build_py):
    """The pure-Python files come with the extension's copy (CMake's package layout); nothing else to do."""

    def run(self):
        self.run_command("build_ext")


with open(os.path.join(HERE, "README.md"), encoding="utf-8") as f:
    long_description = f.read()

setup(
    name="atacom",
    version=project_version(),
    description="Safe robot RL on CPU: ATACOM (acting on the tangent space of the constraint manifold), "
                "batched envs as a Gymnasium vector env, the projector as NumPy functions",
    long_description=long_description,
    long_description_content_type="text/markdown",
    license="see the repository",
    python_requires=">=3.8",
    # NumPy is needed at run time; Debian's python3-numpy satisfies it (no download with --no-deps or
    # a venv made with --system-site-packages).
    install_requires=["numpy"],
    extras_require={"gymnasium": ["gymnasium>=1.0"]},
    packages=["atacom"],
    package_dir={"atacom": "python/atacom"},
    ext_modules=[CMakeExtension()],
    cmdclass={"build_ext": BuildWithCMake, "build_py": BuildPy},
    zip_safe=False,
    options={"build": {"build_base": os.path.join("build", "pip-setuptools")},
             "egg_info": {"egg_base": os.path.join("build")}},
)
