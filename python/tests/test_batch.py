"""align3d.batch on a 2-worker LocalCluster: reports in input order equal to register()'s for the
same pair, a missing file gives an error naming it while the others finish, the result does not
depend on the number of workers, and the command writes one report per pair and resumes."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import align3d

pytest.importorskip("distributed")
from dask.distributed import Client, LocalCluster  # noqa: E402

from conftest import rigid, surface  # noqa: E402


@pytest.fixture(scope="module")
def pairs(tmp_path_factory):
    """Three scans of one model moved by known transforms, as files, plus a missing scan."""
    d = tmp_path_factory.mktemp("batch")
    model = surface(5000, seed=8)
    align3d.write_point_cloud(d / "model.ply", model)
    out, truths = [], []
    for k, angle in enumerate([5, 70, 140]):
        T = rigid([0.2, 1, 0.4], angle, [0.2 * k, 0.1, -0.3])
        align3d.write_point_cloud(d / f"scan{k}.ply", model[k::2] @ T[:3, :3].T + T[:3, 3])
        out.append((str(d / f"scan{k}.ply"), str(d / "model.ply")))
        truths.append(np.linalg.inv(T))
    out.insert(1, (str(d / "missing.ply"), str(d / "model.ply")))
    return d, out, truths


@pytest.fixture(scope="module")
def cluster():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as c, Client(c) as client:
        yield client


def test_reports_in_input_order_and_a_missing_file_named(pairs, cluster):
    _, todo, truths = pairs
    reports = align3d.batch.register_pairs(todo, cluster, init="global")
    assert len(reports) == 4
    assert "error" in reports[1] and "missing.ply" in reports[1]["error"]
    assert reports[1]["code"] == 3
    good = [r for i, r in enumerate(reports) if i != 1]
    for (source, target), report, truth in zip([todo[0], todo[2], todo[3]], good, truths):
        assert report["source"]["path"] == source
        direct = align3d.register(source, target, init="global").to_dict()
        assert report["transformation"] == direct["transformation"]
        assert np.allclose(np.array(report["transformation"]), truth, atol=2e-3)


def test_the_result_does_not_depend_on_workers_or_grouping(pairs, cluster):
    _, todo, _ = pairs
    two = align3d.batch.register_pairs(todo, cluster, group=3)
    one = align3d.batch.register_pairs(todo, None, workers=1)
    for a, b in zip(one, two):
        assert a.get("transformation") == b.get("transformation")
        assert a.get("error") == b.get("error")


def test_bad_arguments_raise(cluster):
    with pytest.raises(ValueError):
        align3d.batch.register_pairs([("a.ply",)], cluster)
    with pytest.raises(ValueError):
        align3d.batch.register_pairs([], cluster, group=0)
    assert align3d.batch.register_pairs([], cluster) == []


def test_the_command_writes_one_report_per_pair_and_resumes(pairs, tmp_path):
    d, todo, _ = pairs
    csv = tmp_path / "pairs.csv"
    csv.write_text("source,target\n" + "".join(f"{s},{t}\n" for s, t in todo))
    reports = tmp_path / "reports"
    cmd = [sys.executable, "-m", "align3d.batch", str(csv), "--report-dir", str(reports),
           "--workers", "2", "--quiet"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 8, run.stderr  # one pair failed
    assert "missing.ply" in run.stderr
    names = sorted(os.listdir(reports))
    assert names == ["missing--model.failed.json", "scan0--model.json", "scan1--model.json",
                     "scan2--model.json"]
    assert "error" in json.loads((reports / "missing--model.failed.json").read_text())
    os.remove(reports / "scan1--model.json")
    before = (reports / "scan0--model.json").stat().st_mtime_ns
    run = subprocess.run(cmd[:-1], capture_output=True, text=True)
    assert "2 of 4 pairs have reports already" in run.stdout
    assert (reports / "scan1--model.json").exists()
    assert (reports / "scan0--model.json").stat().st_mtime_ns == before  # skipped
    bad = tmp_path / "bad.csv"
    bad.write_text("only-one-column\n")
    run = subprocess.run(cmd[:3] + [str(bad), "--report-dir", str(reports)], capture_output=True,
                         text=True)
    assert run.returncode == 3 and "bad.csv" in run.stderr


def test_the_align3d_batch_front_runs_the_engine(pairs, tmp_path, cli):
    _, todo, _ = pairs
    csv = tmp_path / "pairs.csv"
    csv.write_text("".join(f"{s},{t}\n" for s, t in todo[:1]))
    env = dict(os.environ, ALIGN3D_PYTHON=sys.executable)
    help_text = subprocess.run([str(cli), "batch", "--help"], capture_output=True, text=True,
                               env=env)
    assert help_text.returncode == 0 and "--report-dir" in help_text.stdout
    run = subprocess.run([str(cli), "batch", str(csv), "--report-dir", str(tmp_path / "r"),
                          "--workers", "1", "--quiet"], capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr
    report = json.loads((tmp_path / "r" / "scan0--model.json").read_text())
    direct = align3d.register(todo[0][0], todo[0][1]).to_dict()
    assert report["transformation"] == direct["transformation"]


def test_the_packages_own_command_runs_the_engine_with_its_python(pairs, tmp_path):
    # The wheel's `align3d` (align3d._cli, the tool inside the extension) names no Python: the
    # batch engine runs with the interpreter that runs the command, not one baked in at build time.
    _, todo, _ = pairs
    csv = tmp_path / "pairs.csv"
    csv.write_text("".join(f"{s},{t}\n" for s, t in todo[:1]))
    env = {k: v for k, v in os.environ.items() if k != "ALIGN3D_PYTHON"}
    run = subprocess.run([sys.executable, "-m", "align3d._cli", "batch", str(csv), "--report-dir",
                          str(tmp_path / "r"), "--workers", "1", "--quiet"], capture_output=True,
                         text=True, env=env)
    assert run.returncode == 0, run.stderr
    report = json.loads((tmp_path / "r" / "scan0--model.json").read_text())
    direct = align3d.register(todo[0][0], todo[0][1]).to_dict()
    assert report["transformation"] == direct["transformation"]
