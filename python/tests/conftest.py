"""Shared fixtures: a generated scene with known ground truth, and the `align3d` executable the
package's results are compared with (ALIGN3D_CLI, set by scripts/test.sh; else build/align3d)."""

import os
import pathlib

import numpy as np
import pytest

import align3d

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def chapter(tmp_path_factory):
    """The chapter's scene as `align3d synth` writes it (seed 39): scan.ply (source), model.ply
    (target), ground_truth.txt (model ≈ T·scan), plates; returns (directory, scene.json)."""
    directory = tmp_path_factory.mktemp("chapter")
    return directory, align3d.synth(directory)


@pytest.fixture(scope="session")
def cli():
    """Path of the `align3d` executable built from the same tree as the module."""
    path = pathlib.Path(os.environ.get("ALIGN3D_CLI") or REPO / "build" / "align3d")
    if not path.is_file():
        pytest.skip(f"no align3d executable at {path} (set ALIGN3D_CLI)")
    return path


def rotation(axis, angle_deg):
    """Rodrigues' rotation matrix, an oracle independent of the library."""
    k = np.asarray(axis, dtype=float)
    k /= np.linalg.norm(k)
    a = np.radians(angle_deg)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def rigid(axis, angle_deg, translation):
    T = np.eye(4)
    T[:3, :3] = rotation(axis, angle_deg)
    T[:3, 3] = translation
    return T


def pose_error(estimate, truth):
    """(rotation error in degrees, translation error) of two 4x4 transforms."""
    R = estimate[:3, :3].T @ truth[:3, :3]
    angle = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))
    return angle, np.linalg.norm(estimate[:3, 3] - truth[:3, 3])


def surface(n, seed):
    """n points sampled at random on a bumpy sheet with a box on it (no symmetry), units of 1."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-3, 3, size=(n, 2))
    z = 0.4 * np.sin(1.3 * xy[:, 0]) * np.cos(0.9 * xy[:, 1]) + 0.15 * xy[:, 0]
    z += 0.8 * np.exp(-((xy[:, 0] - 1) ** 2 + (xy[:, 1] + 0.5) ** 2) * 2)
    return np.column_stack([xy, z])
