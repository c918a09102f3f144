"""align3d.match_instances: BOP's scoring of found poses, against brute-force ADD-S in numpy."""
import numpy as np
import pytest

import align3d


def pose(angle_deg=0.0, axis=(0, 0, 1), t=(0, 0, 0)):
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    th = np.radians(angle_deg)
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
    T[:3, 3] = t
    return T


def add_s(P, Ta, Tb):  # brute force: mean over x of min over y of |Ta x - Tb y|
    A = P @ Ta[:3, :3].T + Ta[:3, 3]
    B = P @ Tb[:3, :3].T + Tb[:3, 3]
    return np.sqrt(((A[:, None, :] - B[None, :, :]) ** 2).sum(-1).min(1)).mean()


def test_matches_each_pose_to_the_nearest_free_truth_and_counts_as_bop_does():
    P = np.random.default_rng(3).uniform([-50, -30, -15], [50, 30, 15], size=(400, 3))
    truth = [pose(20, (1, 2, 3), (0, 0, 500)), pose(-60, (0, 1, 0), (300, 0, 500))]
    visible = [0.9, 0.3]  # the second too little visible to count
    found = [truth[1],                                  # exact, on the excused instance
             pose(0, t=(2, 0, 0)) @ truth[0],           # 2 mm off the counted one
             pose(90, (1, 0, 0), (-400, 0, 500))]       # nowhere near either
    m = align3d.match_instances(P, found, truth, visible, 10.0)
    assert m["match"] == [1, 0, -1]
    assert (m["counted"], m["true_positives"], m["excused"], m["false_positives"]) == (1, 1, 1, 1)
    assert m["recall"] == 1.0 and m["precision"] == 0.5
    assert m["error"][0] == pytest.approx(0.0, abs=1e-9)
    assert m["error"][1] == pytest.approx(add_s(P, found[1], truth[0]), rel=1e-9)
    assert 0 < m["error"][1] <= 2.0
    nearest = min(add_s(P, found[2], T) for T in truth)
    assert m["error"][2] == pytest.approx(nearest, rel=1e-9) and nearest > 10.0
    # A looser bound lets the far pose take nothing either: both truths are already matched.
    loose = align3d.match_instances(P, found, truth, visible, 1e4)
    assert loose["match"] == [1, 0, -1]


def test_a_turn_about_the_axis_of_a_ring_is_no_error():
    th = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    ring = np.c_[50 * np.cos(th), 50 * np.sin(th), np.zeros_like(th)]
    T = pose(0, t=(0, 0, 400))
    m = align3d.match_instances(ring, [T @ pose(30)], [T], [1.0], 1.0)
    assert m["match"] == [0] and m["error"][0] < 0.05  # ADD (no nearest point) would be 25.9
    assert m["recall"] == 1.0 and m["precision"] == 1.0


def test_nothing_found_in_an_empty_scene_is_perfect():
    m = align3d.match_instances(np.zeros((1, 3)), [], [], [], 1.0)
    assert m["recall"] == 1.0 and m["precision"] == 1.0 and m["match"] == []


def test_bad_arguments_are_value_errors_naming_the_argument():
    P, T = np.zeros((5, 3)), np.eye(4)
    with pytest.raises(ValueError, match="model_points"):
        align3d.match_instances(np.zeros((5, 2)), [T], [T], [1.0], 1.0)
    with pytest.raises(ValueError, match=r"found\[0\]"):
        align3d.match_instances(P, [np.eye(3)], [T], [1.0], 1.0)
    with pytest.raises(ValueError, match="visible"):
        align3d.match_instances(P, [T], [T], [1.0, 0.5], 1.0)
    with pytest.raises(ValueError, match="max_error"):
        align3d.match_instances(P, [T], [T], [1.0], float("nan"))
    skew = np.eye(4)
    skew[0, 1] = 0.5  # not a rotation: the library's rigidity check names it
    with pytest.raises(ValueError, match=r"truth\[0\]"):
        align3d.match_instances(P, [T], [skew], [1.0], 1.0)
    with pytest.raises(align3d.DataError, match="model_points"):
        align3d.match_instances(np.full((3, 3), np.nan), [T], [T], [1.0], 1.0)
