"""align3d.stitch: its argument checks, its result against the command line's report (the same
C++ report function), and, on generated scans with known poses (`align3d synth --scene stitch`),
the poses. Tests that need the engine skip while src/stitch.cpp is a placeholder."""

import inspect
import json
import re
import subprocess
import warnings

import numpy as np
import pytest

import align3d

from conftest import pose_error, surface


def stitched(*args, **kwargs):
    """align3d.stitch, skipping the test while the engine is a placeholder."""
    try:
        return align3d.stitch(*args, **kwargs)
    except RuntimeError as e:
        if "not implemented yet" in str(e):
            pytest.skip(f"the stitch engine is not there yet: {e}")
        raise


@pytest.fixture(scope="module")
def scene(tmp_path_factory, cli):
    """A ring of 8 range scans of the bracket 45° apart plus a leaf view looking up at its
    underside, each in its own sensor frame; truth.json has each pose in scan_00's frame."""
    directory = tmp_path_factory.mktemp("stitch")
    subprocess.run([str(cli), "synth", "--scene", "stitch", str(directory)], check=True,
                   capture_output=True)
    truth = json.loads((directory / "truth.json").read_text())
    files = [directory / s["file"] for s in truth["scans"]]
    return directory, truth, files


@pytest.fixture(scope="module")
def result(scene, tmp_path_factory):
    """stitch() of the scene's files, with every output written into its own folder."""
    _, _, files = scene
    out = tmp_path_factory.mktemp("stitch_out")
    r = stitched(files, threads=2, report=out / "r.json", output=out / "merged.ply",
                 figure=out / "f.png", html=out / "page.html")
    return r, out


def test_bad_arguments_raise_naming_the_problem(tmp_path):
    a = surface(500, 1)
    with pytest.raises(align3d.DataError, match="at least two"):
        align3d.stitch([a])
    with pytest.raises(align3d.DataError, match="at least two"):
        align3d.stitch([])
    with pytest.raises(TypeError, match="list of scans"):
        align3d.stitch(a)
    with pytest.raises(TypeError, match="list of scans"):
        align3d.stitch("scan.ply")
    with pytest.raises(ValueError, match=r"scans\[1\].*shape \(500, 2\)"):
        align3d.stitch([a, a[:, :2]])
    with pytest.raises(ValueError, match=r"scans\[1\].*dtype"):
        align3d.stitch([a, np.array([["x", "y", "z"]])])
    bad = a.copy()
    bad[7, 1] = np.nan
    with pytest.raises(align3d.DataError, match=r"scans\[2\]") as e:
        align3d.stitch([a, a, bad])
    assert e.value.subject == "scans[2]"
    missing = tmp_path / "nowhere.ply"
    with pytest.raises(align3d.FileError) as e:
        align3d.stitch([a, missing])
    assert e.value.path == str(missing)
    with pytest.raises(ValueError, match="viewpoints"):
        align3d.stitch([a, a], viewpoints=np.zeros((3, 3)))
    with pytest.raises(TypeError, match="threads"):
        align3d.stitch([a, a], threads=1.5)
    with pytest.raises(align3d.SettingsError, match="method: expected one of 'point-to-plane'"):
        align3d.stitch([a, a], method="plane")
    with pytest.raises(align3d.SettingsError, match="kernel scale: needs a kernel"):
        align3d.stitch([a, a], kernel_scale=1.0)
    with pytest.raises(TypeError, match="kernel"):
        align3d.stitch([a, a], kernel=None)


def test_keywords_are_named_after_the_cli_flags(cli):
    text = subprocess.run([str(cli), "stitch", "--help"], capture_output=True, text=True).stdout
    flags = {f.replace("-", "_") for f in re.findall(r"^\s+(?:-\w,\s*)?--([a-z][a-z-]*)", text,
                                                       re.M)}
    assert "no_scan_index" in flags and "list" in flags
    keywords = set(inspect.signature(align3d.stitch).parameters)
    # --list is the list itself; --no-scan-index is scan_index=False; the package prints nothing.
    for flag in flags - {"help", "quiet", "list", "no_scan_index"}:
        assert flag in keywords, f"align3d stitch --{flag.replace('_', '-')} has no keyword"
    assert "scan_index" in keywords


def test_the_result_reads_its_report(result):
    r, out = result
    report = r.to_dict()
    assert report == r.report == json.loads((out / "r.json").read_text())
    for key in ("poses", "edges", "merged", "diameter", "multiview_iterations", "warnings",
                "timings", "settings"):
        assert key in report, key
    n = len(report["poses"])
    assert n == 9 and len(r.poses) == n and len(r.connected) == n
    for pose in r.poses:
        assert pose.shape == (4, 4) and pose.dtype == np.float64
        np.testing.assert_allclose(pose[3], [0, 0, 0, 1])
    np.testing.assert_array_equal(r.poses[0], np.eye(4))
    assert r.connected[0]
    # Each scan's warnings are the report's that name it: an unconnected scan has its warning.
    assert r.scan_warnings == [p["warnings"] for p in report["poses"]]
    for k in range(n):
        assert ("unconnected_scan" in r.scan_warnings[k]) == (not r.connected[k])
        for code in r.scan_warnings[k]:
            assert code in {w["code"] for w in report["warnings"]}
    for e in r.edges:
        assert e["transformation"].shape == (4, 4) and e["information"].shape == (6, 6)
        assert 0 <= e["source"] < e["target"] < n
        assert e["kept"] == (e["status"] == "")
    assert isinstance(r.merged, align3d.PointCloud) and r.merged.has_normals
    assert r.merged_scan.dtype == np.int32 and r.merged_scan.shape == (len(r.merged),)
    assert not r.merged_scan.flags.writeable
    assert set(np.unique(r.merged_scan)) <= {k for k in range(n) if r.connected[k]}
    assert report["merged"] == {"file": str(out / "merged.ply"), "points": len(r.merged),
                                "voxel": report["merged"]["voxel"], "scan_index": True}
    back = align3d.read_point_cloud(out / "merged.ply")
    np.testing.assert_allclose(back.points, r.merged.points, atol=1e-4)  # float32 in the file
    assert (out / "f.png").stat().st_size > 0
    assert "data:image/png;base64," in (out / "page.html").read_text()
    assert "StitchResult of 9 scans" in repr(r)
    with pytest.raises(AttributeError, match="poses"):
        r.transformation


def test_python_and_the_command_line_write_the_same_report(scene, result, cli, tmp_path):
    _, _, files = scene
    r, out = result
    subprocess.run([str(cli), "stitch", *map(str, files), "--threads", "2", "--output",
                    str(out / "merged.ply"), "--report", str(tmp_path / "cli.json"), "--quiet"],
                   check=False)
    from_cli = json.loads((tmp_path / "cli.json").read_text())
    from_python = r.to_dict()
    for report in (from_cli, from_python):
        report.pop("timings")
    assert from_python == from_cli


def test_the_icp_cost_reaches_the_report_as_on_the_command_line(scene, cli, tmp_path):
    _, _, files = scene
    # Four neighbours of the ring: enough to check the cost's way through. Warnings, if any, are
    # compared through the reports.
    files = files[:4]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", align3d.AlignWarning)
        ours = stitched(files, threads=2, method="gicp", kernel="cauchy",
                        kernel_scale=0.5).to_dict()
    subprocess.run([str(cli), "stitch", *map(str, files), "--threads", "2", "--method", "gicp",
                    "--kernel", "cauchy", "--kernel-scale", "0.5", "--report",
                    str(tmp_path / "cli.json"), "--quiet"], check=False)
    theirs = json.loads((tmp_path / "cli.json").read_text())
    for report in (ours, theirs):
        report.pop("timings")
    assert ours == theirs
    assert ours["settings"]["icp"] == {"method": "gicp", "kernel": "cauchy", "kernel_scale": 0.5}


def test_mixed_inputs_and_no_scan_index(scene, tmp_path):
    _, _, files = scene
    first = align3d.read_point_cloud(files[0])
    second = align3d.read_point_cloud(files[1]).points  # a plain array
    r = stitched([first, second, files[2]], threads=2, scan_index=False,
                 output=tmp_path / "plain.ply")
    report = r.to_dict()
    assert [p["file"] for p in report["poses"]] == ["", "", str(files[2])]
    assert report["merged"]["scan_index"] is False
    assert b"scan" not in (tmp_path / "plain.ply").read_bytes()[:400]
    # No sensor known (arrays, PLY files): each placed by the engine, at the origin the generated
    # views were seen from.
    assert report["settings"]["viewpoints"] == [None] * 3
    assert [p["sensor"]["source"] for p in report["poses"]] == ["origin"] * 3
    given = stitched(files[:2], threads=2, viewpoints=[[0, 0, 0], [np.nan] * 3]).to_dict()
    assert [p["sensor"]["source"] for p in given["poses"]] == ["given", "origin"]
    one = stitched(files[:2], threads=2, viewpoint=[0, 0, 0]).to_dict()
    assert [p["sensor"]["source"] for p in one["poses"]] == ["given", "given"]
    with pytest.raises(ValueError, match="viewpoint"):
        align3d.stitch(files[:2], viewpoint=[0, 0])
    with pytest.raises(ValueError, match="one or the other"):
        align3d.stitch(files[:2], viewpoint=[0, 0, 0], viewpoints=np.zeros((2, 3)))
