"""register() and rectify() against independent truth, and their reports against the CLI's."""

import json
import subprocess
import warnings

import numpy as np
import pytest

import align3d
from conftest import pose_error, rigid, rotation, surface


def scene_files(chapter):
    directory, _ = chapter
    return directory / "scan.ply", directory / "model.ply", directory / "ground_truth.txt"


# --- truth -------------------------------------------------------------------------------------


def test_a_numpy_scene_moved_by_a_known_transform_is_recovered():
    # Two independent samplings of one surface; the source is seen from a pose T_true⁻¹.
    T_true = rigid([1, 2, 3], 9.0, [0.2, -0.1, 0.15])
    target = surface(6000, seed=1)
    seen = surface(5000, seed=2)
    source = (seen - T_true[:3, 3]) @ T_true[:3, :3]  # target ≈ T_true·source
    result = align3d.register(source, target)
    rotation_error, translation_error = pose_error(result.transformation, T_true)
    assert rotation_error < 0.05 and translation_error < 0.005
    assert result.converged and result.success
    assert result.transformation.shape == (4, 4)
    np.testing.assert_array_equal(result.transformation[3], [0, 0, 0, 1])


@pytest.mark.parametrize("method", ["point-to-point", "point-to-plane", "gicp", "symmetric"])
@pytest.mark.parametrize("kernel", ["auto", "cauchy"])
def test_every_method_and_kernel_recovers_a_known_transform(method, kernel):
    T_true = rigid([1, 2, 3], 9.0, [0.2, -0.1, 0.15])
    target = surface(6000, seed=1)
    source = (surface(5000, seed=2) - T_true[:3, 3]) @ T_true[:3, :3]
    with warnings.catch_warnings():
        # point-to-point's RMS is the full distance, the samplings' offsets included, which the
        # noise check (docs/report.md, rms_above_noise) reads as a misfit
        warnings.simplefilter("ignore" if method == "point-to-point" else "error",
                              align3d.AlignWarning)
        result = align3d.register(source, target, init="identity", method=method, kernel=kernel)
    rotation_error, translation_error = pose_error(result.transformation, T_true)
    assert rotation_error < 0.1 and translation_error < 0.01
    assert result.to_dict()["method"] == method and result.to_dict()["kernel"] == kernel
    covariance = result.covariance
    assert covariance.shape == (6, 6)
    np.testing.assert_allclose(covariance, covariance.T, rtol=1e-9, atol=1e-18)
    assert np.all(np.linalg.eigvalsh(covariance) > 0)
    # Gauss-Newton steps run to the stationary point; point-to-point's closed-form step converges
    # linearly and stops nearer than the stopped_short warning's 2 standard deviations
    assert 0 <= result.pending_sigmas < (2 if method == "point-to-point" else 0.5)


def test_the_same_scene_in_other_units_gives_the_same_pose():
    T_true = rigid([0, 1, 1], 6.0, [0.1, 0.3, -0.2])
    target = surface(4000, seed=3)
    source = (surface(4000, seed=4) - T_true[:3, 3]) @ T_true[:3, :3]
    in_units = align3d.register(source, target).transformation
    in_thousandths = align3d.register(source * 1000, target * 1000).transformation
    np.testing.assert_allclose(in_thousandths[:3, :3], in_units[:3, :3], atol=1e-6)
    np.testing.assert_allclose(in_thousandths[:3, 3] / 1000, in_units[:3, 3], atol=1e-6)


def test_the_chapter_scene_against_its_ground_truth(chapter):
    scan, model, truth_file = scene_files(chapter)
    truth = align3d.read_matrix(truth_file)
    result = align3d.register(scan, model, ground_truth=truth_file)
    rotation_error, translation_error = pose_error(result.transformation, truth)
    assert rotation_error < 0.1 and translation_error < 0.05  # mm; the scan's noise is 0.1 mm
    assert result.rotation_error_deg == pytest.approx(rotation_error, abs=1e-6)
    assert result.translation_error == pytest.approx(translation_error, abs=1e-9)
    assert result.warnings == []


def test_init_as_a_pose_starts_icp_there(chapter):
    scan, model, truth_file = scene_files(chapter)
    truth = align3d.read_matrix(truth_file)
    bad = rigid([0, 0, 1], 40.0, [0, 0, 0]) @ truth  # the chapter's bad initial value
    from_truth = align3d.register(scan, model, init=truth, method="point-to-point",
                                  reject="median:2.5:0.5")
    assert from_truth.init["policy"] == "pose"
    assert pose_error(from_truth.transformation, truth)[0] < 0.5
    with pytest.warns(align3d.AlignWarning):
        from_bad = align3d.register(scan, model, init=bad, method="point-to-point",
                                    reject="median:2.5:0.5")
    assert pose_error(from_bad.transformation, truth)[0] > 10  # the chapter's wrong minimum
    assert {w.code for w in from_bad.warnings} >= {"weak_overlap"}
    from_file = align3d.register(scan, model, init=truth_file, method="point-to-point",
                                 reject="median:2.5:0.5")
    np.testing.assert_allclose(from_file.transformation, from_truth.transformation, atol=1e-12)


def test_global_init_finds_a_pose_from_anywhere(chapter):
    scan, model, truth_file = scene_files(chapter)
    truth = align3d.read_matrix(truth_file)
    cloud = align3d.read_point_cloud(scan)
    turned = cloud.transformed(rigid([1, 1, 0], 150.0, [30, -20, 10]))
    result = align3d.register(turned, model, init="global")
    expected = truth @ np.linalg.inv(rigid([1, 1, 0], 150.0, [30, -20, 10]))
    assert pose_error(result.transformation, expected)[0] < 0.1
    assert result.global_stage["success"] and result.global_stage["method"] == "fpfh"
    assert result.init["path"] == "global"


def test_result_attributes_read_the_report(chapter):
    scan, model, _ = scene_files(chapter)
    result = align3d.register(scan, model)
    d = result.to_dict()
    assert result.rms == d["rms"] and result.fitness == d["fitness"]
    assert result.iterations == d["iterations"] == sum(s["iterations"] for s in result.stages)
    assert len(result.history) == result.iterations + len(result.stages)
    assert result.stop_reason in ("rms_change", "transform_change", "cycle")
    np.testing.assert_array_equal(result.transformation, d["transformation"])
    np.testing.assert_array_equal(result.translation, result.transformation[:3, 3])
    assert result.support["overlap"] > 0.5
    assert result.global_stage is None and result.init["reason"] == ""
    assert result.icp_direction == "source onto target"
    assert result.rotation_error_deg is None
    assert "rms=" in repr(result)
    result.to_dict()["rms"] = -1  # a copy
    assert result.rms == d["rms"]


def test_rectify_levels_a_tilted_plane():
    rng = np.random.default_rng(8)
    flat = np.column_stack([rng.uniform(-50, 50, (3000, 2)), rng.normal(0, 0.01, 3000)])
    R = rotation([1, 0.3, 0], 7.0)
    tilted = flat @ R.T + [0, 0, 20]
    result = align3d.rectify(tilted)
    assert result.tilt_before_deg == pytest.approx(7.0, abs=0.01)
    assert result.tilt_after_deg < 1e-3
    np.testing.assert_allclose(result.normal, R[:, 2], atol=1e-4)
    levelled = align3d.PointCloud(tilted).transformed(result.transformation).points
    assert np.abs(levelled[:, 2]).max() < 0.1
    with pytest.raises(align3d.DataError, match=r"all points lie on one line: no plane"):
        align3d.rectify(np.column_stack([np.arange(10.0), np.zeros(10), np.zeros(10)]))
    with pytest.raises(align3d.SettingsError, match=r"finite non-zero"):
        align3d.rectify(tilted, up=[0, 0, 0])


# --- the report, key for key the CLI's -------------------------------------------------------

TIMINGS = {("timing_ms",), ("global", "time_ms")}


def assert_same_report(ours, theirs, where=()):
    """Same keys at every level and the same values, except the timings (value only)."""
    if isinstance(theirs, dict):
        assert isinstance(ours, dict), where
        assert sorted(ours) == sorted(theirs), f"keys differ at {where}"
        for key in theirs:
            if (*where, key) in TIMINGS or where[-1:] == ("timing_ms",):
                continue
            assert_same_report(ours[key], theirs[key], (*where, key))
    elif isinstance(theirs, list):
        assert isinstance(ours, list) and len(ours) == len(theirs), where
        for i, (a, b) in enumerate(zip(ours, theirs)):
            assert_same_report(a, b, (*where, i))
    else:
        assert ours == theirs, f"{where}: {ours!r} != {theirs!r}"


def cli_report(cli, *args):
    done = subprocess.run([str(cli), "register", *map(str, args), "--report", "-", "--quiet"],
                          capture_output=True, text=True, check=False)
    assert done.returncode in (0, 7), done.stderr
    return json.loads(done.stdout)


CASES = {
    "defaults": ({}, []),
    "chapter point-to-point": (
        dict(init="identity", method="point-to-point", reject="median:2.5:0.5"),
        ["--init", "identity", "--method", "point-to-point", "--reject", "median:2.5:0.5"],
    ),
    "global ppf": (dict(init="global", global_method="ppf", seed=7),
                   ["--init", "global", "--global", "ppf", "--seed", "7"]),
    "global fpfh mutual": (dict(init="global", mutual=True, voxel=2.0, threads=1),
                           ["--init", "global", "--mutual", "--voxel", "2", "--threads", "1"]),
    "capped": (dict(max_iterations=3, tolerance=1e-3, normal_k=12),
               ["--max-iterations", "3", "--tolerance", "0.001", "--normal-k", "12"]),
    "symmetric huber": (dict(method="symmetric", kernel="huber", kernel_scale=0.3),
                        ["--method", "symmetric", "--kernel", "huber", "--kernel-scale", "0.3"]),
    "gicp": (dict(method="gicp"), ["--method", "gicp"]),
}


@pytest.mark.parametrize("case", CASES)
def test_to_dict_is_the_cli_report(chapter, cli, case):
    scan, model, truth = scene_files(chapter)
    keywords, flags = CASES[case]
    theirs = cli_report(cli, scan, model, "--ground-truth", truth, *flags)
    with warnings.catch_warnings():  # some cases warn, as the CLI does on stderr
        warnings.simplefilter("ignore", align3d.AlignWarning)
        ours = align3d.register(str(scan), str(model), ground_truth=str(truth), **keywords)
    assert_same_report(ours.to_dict(), theirs)
    assert ours.to_dict()["timing_ms"].keys() == theirs["timing_ms"].keys()


@pytest.mark.parametrize("plate, keywords, flags", [
    ("plate.ply", {}, []),
    ("plate_cluttered.ply", dict(fit="lsq"), ["--fit", "lsq"]),
    ("plate.ply", dict(up=[0, 0, -1], seed=4), ["--up", "0,0,-1", "--seed", "4"]),
])
def test_rectify_to_dict_is_the_cli_report(chapter, cli, plate, keywords, flags):
    path = chapter[0] / plate
    done = subprocess.run([str(cli), "rectify", str(path), "--report", "-", *flags],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", align3d.AlignWarning)  # the lsq fit warns not_flat
        ours = align3d.rectify(str(path), **keywords)
    assert ours.to_dict() == json.loads(done.stdout)  # no timings: equal throughout


def test_in_memory_clouds_give_the_same_report_without_paths(chapter):
    scan, model, _ = scene_files(chapter)
    from_files = align3d.register(scan, model).to_dict()
    in_memory = align3d.register(align3d.read_point_cloud(scan),
                                 align3d.read_point_cloud(model)).to_dict()
    assert in_memory["source"] == {"path": "", "points": from_files["source"]["points"]}
    assert in_memory["timing_ms"]["read"] == 0
    for d in (from_files, in_memory):
        del d["source"]["path"], d["target"]["path"]
    assert_same_report(in_memory, from_files)


def test_report_and_output_files(chapter, tmp_path, capsys):
    scan, model, _ = scene_files(chapter)
    result = align3d.register(scan, model, report=tmp_path / "r.json",
                              output=tmp_path / "aligned.ply")
    assert json.loads((tmp_path / "r.json").read_text()) == result.to_dict()
    aligned = align3d.read_point_cloud(tmp_path / "aligned.ply").points
    moved = align3d.read_point_cloud(scan).transformed(result.transformation).points
    np.testing.assert_allclose(aligned, moved, rtol=1e-6, atol=1e-4)  # float32 in the file
    printed = align3d.register(scan, model, report="-")
    assert_same_report(json.loads(capsys.readouterr().out), printed.to_dict())


def test_strict_raises_after_writing_outputs(chapter, tmp_path):
    scan, model, _ = scene_files(chapter)
    chapter_p2p = dict(init="identity", method="point-to-point", reject="median:2.5:0.5")
    with pytest.warns(align3d.AlignWarning) as issued:
        with pytest.raises(align3d.StrictError) as raised:
            align3d.register(scan, model, strict=True, report=tmp_path / "r.json", **chapter_p2p)
    codes = {w.code for w in raised.value.warnings}
    # the chapter's point-to-point (README), still creeping at the cap
    assert {"not_converged", "stopped_short"} <= codes
    assert raised.value.result.pending_sigmas > 2
    assert {w.message.code for w in issued} == codes
    assert raised.value.code == 7 and (tmp_path / "r.json").is_file()
    assert isinstance(raised.value.result, align3d.Result)


def test_no_solution_raises_with_the_report_and_writes_no_output(chapter, tmp_path):
    scan, model, _ = scene_files(chapter)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", align3d.AlignWarning)
        with pytest.raises(align3d.NoSolutionError, match=r"no solution: too few") as raised:
            align3d.register(scan, model, reject="distance:1e-6", report=tmp_path / "r.json",
                             output=tmp_path / "aligned.ply")
    assert raised.value.code == 6 and not raised.value.result.success
    assert json.loads((tmp_path / "r.json").read_text())["success"] is False
    assert not (tmp_path / "aligned.ply").exists()


def test_progress_is_called_and_its_exception_reraised(chapter):
    scan, model, _ = scene_files(chapter)
    calls = []
    align3d.register(scan, model, progress=lambda *a: calls.append(a))
    assert calls and all(isinstance(t, str) and isinstance(d, int) for t, d, _ in calls)

    def fail(task, done, total):
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        align3d.register(scan, model, progress=fail)


# --- errors ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "keywords, message",
    [
        (dict(method="plane"), r"method: expected one of 'point-to-plane', 'point-to-point', "
                               r"'gicp', 'symmetric'"),
        (dict(kernel="gm"), r"kernel: expected one of 'auto', 'none', 'huber'"),
        (dict(kernel_scale=1.0), r"kernel scale: needs a kernel"),
        (dict(kernel="huber", kernel_scale=-1.0), r"kernel scale: expected a finite number"),
        (dict(global_method="ransac"), r"global_method: expected one of 'fpfh', 'ppf'"),
        (dict(reject="median:x"), r"^reject: "),
        (dict(max_iterations=0), r"max_iterations must be at least 1, got 0"),
        (dict(tolerance=-1.0), r"rms_change must be a finite number >= 0"),
        (dict(tolerance=float("nan")), r"rms_change must be a finite number >= 0"),
        (dict(normal_k=2), r"normals.k must be at least 3"),
        (dict(threads=-1), r"threads must be >= 0"),
        (dict(voxel=float("inf")), r"voxel must be a finite number >= 0"),
        (dict(seed=-1), r"seed: -1 is out of range"),
        (dict(max_iterations=2**40), r"max_iterations: 1099511627776 is out of range"),
        (dict(init=np.diag([2.0, 2, 2, 1])), r"^init: rotation is not orthonormal"),
        (dict(ground_truth=np.diag([1.0, 1, -1, 1])), r"^ground_truth: rotation has determinant"),
    ],
)
def test_settings_no_run_can_use_are_settings_errors(keywords, message):
    cloud = surface(200, seed=1)
    with pytest.raises(align3d.SettingsError, match=message) as raised:
        align3d.register(cloud, cloud, **keywords)
    assert raised.value.code == 2 and isinstance(raised.value, ValueError)


def test_ppf_model_excludes_identity_init_and_a_voxel(tmp_path):
    cloud = surface(2000, seed=1)
    align3d.write_point_cloud(tmp_path / "m.ply", cloud)
    align3d.ppf_model(tmp_path / "m.ply", tmp_path / "m.ppf")
    with pytest.raises(align3d.SettingsError, match=r"ppf_model needs init global or auto"):
        align3d.register(cloud, cloud, ppf_model=tmp_path / "m.ppf", init="identity")
    with pytest.raises(align3d.SettingsError, match=r"voxel with a ppf_model"):
        align3d.register(cloud, cloud, ppf_model=tmp_path / "m.ppf", voxel=1.0)


@pytest.mark.parametrize(
    "keywords, error",
    [
        (dict(max_iterations="5"), TypeError),
        (dict(max_iterations=2.5), TypeError),
        (dict(tolerance="1e-5"), TypeError),
        (dict(method=1), TypeError),
        (dict(progress=5), TypeError),
        (dict(init=np.eye(3)), ValueError),
        (dict(ground_truth=[[1, 0], [0, 1]]), ValueError),
    ],
)
def test_keywords_of_the_wrong_type(keywords, error):
    cloud = surface(200, seed=1)
    with pytest.raises(error):
        align3d.register(cloud, cloud, **keywords)


def test_clouds_that_cannot_be_registered_are_data_errors(tmp_path):
    good = surface(500, seed=1)
    with pytest.raises(align3d.DataError, match=r"^source: 5 points; registration needs at least"):
        align3d.register(good[:5], good)
    line = np.column_stack([np.arange(50.0), np.zeros(50), np.zeros(50)])
    with pytest.raises(align3d.DataError, match=r"^target: all points lie on one line") as raised:
        align3d.register(good, line)
    assert raised.value.subject == "target" and raised.value.code == 4
    align3d.write_point_cloud(tmp_path / "line.xyz", line)
    with pytest.raises(align3d.DataError) as raised:  # named by its file, as the CLI does
        align3d.register(good, tmp_path / "line.xyz")
    assert str(raised.value) == f"{tmp_path / 'line.xyz'} (target): all points lie on one line"
    cloud = align3d.PointCloud(good)
    cloud.points[3] = np.nan  # written through the view, after construction
    with pytest.raises(align3d.DataError, match=r"^source: point 3 has a NaN or Inf"):
        align3d.register(cloud, good)


def test_help_explains_units_and_convention():
    doc = align3d.register.__doc__
    assert "target ≈ T·source" in doc and "row-major" in doc
    assert "data's units" in doc and "global_method" in doc
    assert "4x4" in align3d.rectify.__doc__
