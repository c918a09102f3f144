"""The align3d Python package: python/align3d/ and the extension module align3d._core, built by
CMake (python/CMakeLists.txt, target align3d_python).

Offline, from Debian's packages (scripts/setup.sh: python3-pybind11, pybind11-dev, numpy,
setuptools, wheel):

    pip install --no-build-isolation --no-index .

The C++ is compiled once:
  - ALIGN3D_CMAKE_BUILD_DIR=DIR reuses a tree configured with -DALIGN3D_PYTHON=ON (scripts/build.sh
    passes build/) and builds only the module there (nothing, when it is up to date);
  - otherwise a tree of its own, build-python/cmake (Release, no tests), is configured on first use
    and kept, so a second install builds only what changed.
A wheel (scripts/wheel.sh) is made the same way, from Debian's pip:

    ALIGN3D_CMAKE_BUILD_DIR=build pip wheel --no-build-isolation --no-index --no-deps -w dist .

It carries the `align3d` command as a console script (align3d/_cli.py: the tool run inside the
extension). The version is CMakeLists.txt's project() version, read below.
JOBS (or CMAKE_BUILD_PARALLEL_LEVEL) sets the parallel build jobs, default 2; ALIGN3D_OCCT (ON or
OFF) the STEP/IGES reader, default ON when OpenCASCADE's headers are installed. setuptools' own
files go to build-python/ too (not into build/, the CMake tree of scripts/build.sh).
"""

import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
OWN_TREE = ROOT / "build-python"
VERSION = re.search(
    r"project\(align3d VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text()
).group(1)


class CMakeBuild(build_ext):
    """Builds the extension with CMake and copies it where setuptools packs it."""

    def run(self):
        for ext in self.extensions:
            self.build_extension(ext)

    def build_extension(self, ext):
        tree = self._tree()
        jobs = os.environ.get("JOBS") or os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or "2"
        self._cmake("--build", tree, "--target", "align3d_python", "-j", jobs)
        built, *beside = map(Path, (tree / "python" / "extension_path.txt").read_text().splitlines())
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        if not built.name.endswith(suffix):
            sys.exit(
                f"setup.py: {built} was built for another Python than {sys.executable} "
                f"(expected a name ending {suffix}); configure {tree} with "
                f"-DPython3_EXECUTABLE={sys.executable}"
            )
        destination = Path(self.get_ext_fullpath(ext.name))
        destination.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, destination)
        for extra in beside:  # the OpenCASCADE module, looked for beside the extension
            shutil.copyfile(extra, destination.parent / extra.name)

    def _tree(self):
        given = os.environ.get("ALIGN3D_CMAKE_BUILD_DIR")
        if given:
            tree = Path(given) if Path(given).is_absolute() else ROOT / given
            cache = tree / "CMakeCache.txt"
            if not cache.is_file():
                sys.exit(f"setup.py: ALIGN3D_CMAKE_BUILD_DIR={given}: no CMakeCache.txt there")
            if "ALIGN3D_PYTHON:BOOL=ON" not in cache.read_text():
                sys.exit(
                    f"setup.py: ALIGN3D_CMAKE_BUILD_DIR={given} was configured without "
                    "-DALIGN3D_PYTHON=ON"
                )
            return tree
        tree = OWN_TREE / "cmake"
        args = ["-S", ROOT, "-B", tree, "-DCMAKE_BUILD_TYPE=Release", "-DALIGN3D_PYTHON=ON",
                "-DALIGN3D_BUILD_TESTS=OFF", f"-DPython3_EXECUTABLE={sys.executable}"]
        # STEP and IGES as scripts/build.sh builds them: with OpenCASCADE when its headers are
        # installed (scripts/setup.sh), unless ALIGN3D_OCCT says otherwise.
        occt = os.environ.get("ALIGN3D_OCCT")
        if occt is None:
            occt = "ON" if Path("/usr/include/opencascade/Standard_Version.hxx").is_file() else "OFF"
        args.append(f"-DALIGN3D_OCCT={occt}")
        if shutil.which("ninja") and not (tree / "CMakeCache.txt").is_file():
            args += ["-G", "Ninja"]
        try:  # python3-pybind11's CMake files, where pybind11-dev's are not installed
            import pybind11

            args.append(f"-Dpybind11_DIR={pybind11.get_cmake_dir()}")
        except ImportError:
            pass
        self._cmake(*args)
        return tree

    @staticmethod
    def _cmake(*args):
        command = ["cmake", *map(str, args)]
        print(" ".join(command), flush=True)
        subprocess.run(command, check=True)


OWN_TREE.mkdir(exist_ok=True)  # egg_info wants its base to exist
setup(
    name="align3d",
    version=VERSION,
    description="Rigid 3D registration and rectification of point clouds (C++ core)",
    long_description=(ROOT / "docs" / "python.md").read_text(encoding="utf-8"),
    long_description_content_type="text/markdown",
    python_requires=">=3.9",
    install_requires=["numpy"],
    package_dir={"": "python"},
    packages=["align3d"],
    package_data={"align3d": ["py.typed", "*.pyi"]},
    ext_modules=[Extension("align3d._core", sources=[])],
    # The tool itself, run inside the extension (align3d/_cli.py): a wheel brings the command line.
    entry_points={"console_scripts": ["align3d = align3d._cli:main"]},
    cmdclass={"build_ext": CMakeBuild},
    zip_safe=False,
    options={
        "build": {"build_base": str(OWN_TREE / "setuptools")},
        "egg_info": {"egg_base": str(OWN_TREE)},
    },
)
