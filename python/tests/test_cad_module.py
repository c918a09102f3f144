"""OpenCASCADE is a module of its own (src/io/occt_module.hpp): importing align3d or starting the
tool does not load it, the package carries it beside the extension, and a missing or broken module
is a file error naming the STEP file and the module."""

import os
import pathlib
import subprocess
import sys

import pytest

import align3d
from align3d import _core

STEP = "ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\nENDSEC;\nEND-ISO-10303-21;\n"
needs_occt = pytest.mark.skipif(not _core.has_cad_exchange(),
                                reason="align3d built without OpenCASCADE (ALIGN3D_OCCT)")


def loaded_libraries(code):
    """The shared objects a fresh Python has mapped after running `code`."""
    script = f"{code}\nprint(open('/proc/self/maps').read())"
    maps = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          check=True).stdout
    return {pathlib.Path(line.split()[-1]).name for line in maps.splitlines() if ".so" in line}


def test_import_and_reading_a_ply_do_not_load_opencascade(tmp_path):
    cloud = tmp_path / "c.xyz"
    cloud.write_text("0 0 0\n1 0 0\n0 1 0\n")
    names = loaded_libraries(f"import align3d; align3d.read_point_cloud({str(cloud)!r})")
    assert not [n for n in names if n.startswith("libTK") or n.startswith("libalign3d_occt")]


def test_the_tool_does_not_link_opencascade(cli):
    linked = subprocess.run(["ldd", str(cli)], capture_output=True, text=True, check=True).stdout
    assert "libTK" not in linked


@needs_occt
def test_the_package_carries_the_module_beside_the_extension():
    assert (pathlib.Path(_core.__file__).parent / "libalign3d_occt.so").is_file()


@needs_occt
def test_reading_a_step_file_loads_the_module(tmp_path):
    part = tmp_path / "empty.step"
    part.write_text(STEP)
    code = (f"import align3d\ntry: align3d.read_mesh({str(part)!r})\n"
            "except align3d.FileError: pass")
    assert "libalign3d_occt.so" in loaded_libraries(code)


@needs_occt
@pytest.mark.parametrize("module, phrase", [("missing.so", "not found"),
                                            ("not_elf.so", "cannot load")])
def test_a_missing_or_broken_module_is_a_file_error(cli, tmp_path, module, phrase):
    part = tmp_path / "part.step"
    part.write_text(STEP)
    (tmp_path / "not_elf.so").write_text("not a shared object\n")
    environment = dict(os.environ, ALIGN3D_OCCT_MODULE=str(tmp_path / module))
    run = subprocess.run([str(cli), "convert", str(part), str(tmp_path / "out.ply")],
                         capture_output=True, text=True, env=environment)
    assert run.returncode == 3  # an input error (README, "Exit codes")
    assert str(part) in run.stderr and str(tmp_path / module) in run.stderr
    assert phrase in run.stderr and "OpenCASCADE module" in run.stderr
    assert not (tmp_path / "out.ply").exists()
