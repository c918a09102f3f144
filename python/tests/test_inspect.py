"""Meshes and inspect() against independent truth (the generated part's pose, labels and true
deviations) and their reports against the command line's."""

import json
import math
import subprocess

import numpy as np
import pytest

import align3d
from conftest import pose_error


@pytest.fixture(scope="session")
def part(tmp_path_factory):
    """`align3d synth --scene part` with about 60 000 points: (directory, scene.json)."""
    directory = tmp_path_factory.mktemp("part")
    return directory, align3d.synth(directory, scene="part", points=60000)


def truth_of(directory):
    """Labels (0 part, 1 fixture) and true deviations from scan_truth.ply, read by hand."""
    data = (directory / "scan_truth.ply").read_bytes()
    header, body = data.split(b"end_header\n", 1)
    names, types = [], {"float": "<f4", "double": "<f8", "uchar": "u1", "int": "<i4"}
    dtype = []
    for line in header.decode().splitlines():
        words = line.split()
        if words[:1] == ["property"]:
            dtype.append((words[2], types[words[1]]))
    table = np.frombuffer(body, dtype=np.dtype(dtype))
    return table["label"], table["deviation"]


# --- meshes ------------------------------------------------------------------------------------


def cube(size=2.0):
    v = np.array([[x, y, z] for z in (0, size) for y in (0, size) for x in (0, size)], float)
    t = [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
         [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]
    return align3d.TriangleMesh(v, np.array(t))


def test_a_mesh_round_trips_through_every_format(tmp_path):
    mesh = cube()
    assert mesh.area() == pytest.approx(24.0)
    assert mesh.topology()["closed"] and mesh.topology()["signed_volume"] == pytest.approx(8.0)
    for ext in ("stl", "ply", "obj", "off"):
        align3d.write_mesh(tmp_path / f"c.{ext}", mesh)
        back = align3d.read_mesh(tmp_path / f"c.{ext}").cleaned()
        assert len(back) == 12 and back.topology()["signed_volume"] == pytest.approx(8.0)
        assert align3d.is_mesh_file(tmp_path / f"c.{ext}")
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 5  # read-only views


def test_bad_meshes_name_their_problem(tmp_path):
    with pytest.raises(ValueError, match="triangles"):
        align3d.TriangleMesh(np.zeros((3, 3)), np.zeros((1, 2), int))
    with pytest.raises(ValueError, match="integer"):
        align3d.TriangleMesh(np.zeros((3, 3)), np.zeros((1, 3)))
    with pytest.raises(align3d.DataError, match="vertex 7"):
        align3d.TriangleMesh(np.eye(3), [[0, 1, 7]])
    bad = tmp_path / "bad.stl"
    bad.write_text("solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0\n")
    with pytest.raises(align3d.FileError) as e:
        align3d.read_mesh(bad)
    assert e.value.path == str(bad) and "bad.stl" in str(e.value)


# --- inspection --------------------------------------------------------------------------------


def test_inspect_recovers_the_pose_and_measures_the_part(part):
    directory, _ = part
    result = align3d.inspect(directory / "scan.ply", directory / "part.stl", tolerance=0.1)
    truth = align3d.read_matrix(directory / "ground_truth.txt")
    rotation_error, translation_error = pose_error(result.transformation, truth)
    assert rotation_error < 0.01 and translation_error < 0.02
    labels, true_deviation = truth_of(directory)
    d = result.deviations
    assert d.shape == (len(labels),) and not d.flags.writeable
    # The fixture is set apart, the part measured: its deviations are the true ones plus noise.
    assert np.isnan(d[labels == 1]).all() and not np.isnan(d[labels == 0]).any()
    assert result.outliers == int((labels == 1).sum())
    error = d[labels == 0] - true_deviation[labels == 0]
    assert math.sqrt(np.mean(error**2)) < 0.0125
    assert result.verdict == "fail" and not result.passed  # 0.3 mm dents against ±0.1
    assert result.closest_points.shape == (len(d), 3)
    assert (result.triangles[labels == 1] == -1).all() and (result.triangles[labels == 0] >= 0).all()
    assert result.stats["count"] == int((labels == 0).sum())
    assert "FAIL" in repr(result)


def test_the_report_is_the_command_lines(part, cli, tmp_path):
    directory, _ = part
    scan, cad = directory / "scan.ply", directory / "part.stl"
    ours = align3d.inspect(scan, cad, tolerance=(-0.1, 0.4)).to_dict()
    out = subprocess.run([str(cli), "inspect", str(scan), str(cad), "--tolerance", "-0.1,0.4",
                          "--report", "-", "--quiet"], capture_output=True, text=True)
    assert out.returncode == 9, out.stderr  # dents below -0.1 remain
    theirs = json.loads(out.stdout)
    for report in (ours, theirs):
        report.pop("timing_ms")
    assert ours == theirs


def test_the_icp_method_and_kernel_reach_the_report_as_on_the_command_line(part, cli):
    directory, _ = part
    scan, cad = directory / "scan.ply", directory / "part.stl"
    ours = align3d.inspect(scan, cad, tolerance=(-0.1, 0.4), method="symmetric",
                           kernel="tukey").to_dict()
    out = subprocess.run([str(cli), "inspect", str(scan), str(cad), "--tolerance", "-0.1,0.4",
                          "--method", "symmetric", "--kernel", "tukey", "--report", "-",
                          "--quiet"], capture_output=True, text=True)
    theirs = json.loads(out.stdout)
    for report in (ours, theirs):
        report.pop("timing_ms")
    assert ours == theirs
    assert ours["method"] == "symmetric" and ours["kernel"] == "tukey"
    with pytest.raises(align3d.SettingsError, match="method: expected"):
        align3d.inspect(scan, cad, tolerance=0.1, method="plane")


def test_a_prepared_mesh_and_the_files_give_the_same_result(part, tmp_path):
    directory, _ = part
    scan, cad = directory / "scan.ply", directory / "part.stl"
    target = align3d.Target(cad)
    assert target.is_mesh
    a = align3d.inspect(scan, target, tolerance=0.5, html=tmp_path / "p.html",
                        output=tmp_path / "d.ply", csv=tmp_path / "d.csv",
                        histogram=tmp_path / "h.csv", figures=tmp_path / "fig", units="mm")
    b = align3d.inspect(scan, align3d.read_mesh(cad), tolerance=0.5)
    np.testing.assert_array_equal(a.transformation, b.transformation)
    np.testing.assert_array_equal(a.deviations, b.deviations)
    assert a.passed and a.within_tolerance == 1.0
    assert "PASS" in (tmp_path / "p.html").read_text()
    assert (tmp_path / "fig" / "views.png").stat().st_size > 0
    assert len((tmp_path / "d.csv").read_text().splitlines()) == len(a.deviations) + 1
    assert len(align3d.read_point_cloud(tmp_path / "d.ply")) == len(a.deviations)
    # register() takes the mesh as its target too.
    r = align3d.register(scan, cad)
    assert r.to_dict()["target"]["triangles"] == len(align3d.read_mesh(cad))
    np.testing.assert_allclose(r.transformation, a.transformation, atol=1e-6)


def test_bad_arguments_raise_before_any_work(part):
    directory, _ = part
    scan, cad = directory / "scan.ply", directory / "part.stl"
    for band in (0, -0.1, float("nan"), (0.1, 0.2), (0.1, -0.1)):
        with pytest.raises(align3d.SettingsError):
            align3d.inspect(scan, cad, tolerance=band)
    with pytest.raises(TypeError):
        align3d.inspect(scan, cad, tolerance="wide")
    with pytest.raises(TypeError, match="cad"):
        align3d.inspect(scan, np.zeros((3, 3)), tolerance=0.1)
    with pytest.raises(align3d.SettingsError, match="pass_fraction"):
        align3d.inspect(scan, cad, tolerance=0.1, pass_fraction=1.5)
    with pytest.raises(align3d.FileError, match="missing.stl"):
        align3d.inspect(scan, directory / "missing.stl", tolerance=0.1)
