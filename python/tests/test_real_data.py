"""Real range scans (../shared/data/real/, its README): the Stanford dragon's neighbours registered
from an unknown pose with the defaults, and a few of its scans stitched without sensor positions,
against the reference poses of truth.txt. The files are
read in place; the tests fail, saying where the files should be, when they are missing
(ALIGN3D_REAL_DATA names another directory holding stanford-dragon/)."""

import os
import pathlib

import numpy as np
import pytest

import align3d

REPO = pathlib.Path(__file__).resolve().parents[2]
REAL = pathlib.Path(os.environ.get("ALIGN3D_REAL_DATA") or REPO.parent / "shared" / "data" / "real")
DRAGON = REAL / "stanford-dragon"


@pytest.fixture(scope="module")
def truth():
    """{turntable angle: world-from-scan pose} from truth.txt; fails when the scans are missing."""
    if not (DRAGON / "truth.txt").is_file():
        pytest.fail(
            f"the real scans are missing: expected the Stanford dragon at {DRAGON} "
            "(../shared/data/real/ beside the repository, or set ALIGN3D_REAL_DATA)"
        )
    poses = {}
    for line in (DRAGON / "truth.txt").read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        name, *numbers = line.split()
        poses[int(name.split("_")[1].split(".")[0])] = np.array(numbers, float).reshape(4, 4)
    return poses


def scan(angle):
    return DRAGON / f"dragonStandRight_{angle}.ply"


@pytest.mark.parametrize("source, target", [(24, 0), (48, 24)])
def test_dragon_neighbours_are_right_and_unwarned(truth, source, target):
    expected = np.linalg.inv(truth[target]) @ truth[source]
    result = align3d.register(scan(source), scan(target))
    assert result.success, result.failure
    T = result.transformation
    cos = (np.trace(expected[:3, :3].T @ T[:3, :3]) - 1) / 2
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))) < 0.5
    c = align3d.read_point_cloud(scan(source)).points.mean(axis=0)
    miss = (T[:3, :3] @ c + T[:3, 3]) - (expected[:3, :3] @ c + expected[:3, 3])
    assert np.linalg.norm(miss) < 1e-3  # metres
    assert result.warnings == [], [w.code for w in result.warnings]


def test_dragon_scans_without_sensor_positions_stitch(truth):
    """The files carry no sensor; the scanner's origin lies under the statuette: stitch places each
    sensor from its scan and every pose is right in the first scan's frame."""
    angles = [48, 0, 24]
    result = align3d.stitch([scan(a) for a in angles], threads=2)
    report = result.to_dict()
    assert report["warnings"] == []
    for angle, pose in zip(angles, report["poses"]):
        assert pose["connected"] and pose["sensor"]["source"] == "estimated"
        expected = np.linalg.inv(truth[angles[0]]) @ truth[angle]
        T = np.array(pose["transformation"])
        cos = (np.trace(expected[:3, :3].T @ T[:3, :3]) - 1) / 2
        assert np.degrees(np.arccos(np.clip(cos, -1, 1))) < 0.5, angle
        c = align3d.read_point_cloud(scan(angle)).points.mean(axis=0)
        miss = (T[:3, :3] @ c + T[:3, 3]) - (expected[:3, :3] @ c + expected[:3, 3])
        assert np.linalg.norm(miss) < 1e-3, angle  # metres
