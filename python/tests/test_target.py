"""align3d.Target: a model prepared once gives the pose the plain model gives, to the bit, against
the known truth, from many scans and from two threads at once."""

import threading

import numpy as np
import pytest

import align3d

from conftest import pose_error, rigid, surface


def moved_scans(model, angles):
    """The model's points moved by known transforms (and the truths: model ≈ T·scan)."""
    out = []
    for k, angle in enumerate(angles):
        T = rigid([1, 2, -0.5], angle, [0.3 * k, -0.2, 0.1])
        scan = (model[:, :3] @ T[:3, :3].T + T[:3, 3])[::2]
        out.append((scan, np.linalg.inv(T)))
    return out


def test_the_prepared_model_gives_the_plain_models_pose_to_the_bit(chapter):
    directory, _ = chapter
    scan, model = str(directory / "scan.ply"), str(directory / "model.ply")
    truth = align3d.read_matrix(directory / "ground_truth.txt")
    target = align3d.Target(model)
    assert len(target) == 5678 and target.path == model and target.normal_k == 20
    for init in ("auto", "global"):
        plain = align3d.register(scan, model, init=init)
        prepared = align3d.register(scan, target, init=init)
        assert np.array_equal(plain.transformation, prepared.transformation)
        a, b = plain.to_dict(), prepared.to_dict()
        for key in set(a) | set(b):
            if key not in ("timing_ms", "normals", "global"):  # normals: all estimated once
                assert a[key] == b[key], key
        rot, trans = pose_error(prepared.transformation, truth)
        assert rot < 0.05 and trans < 0.05


def test_many_scans_against_one_prepared_array():
    model = surface(6000, seed=3)
    target = align3d.Target(model)
    for scan, truth in moved_scans(model, [5, 40, 120]):
        r = align3d.register(scan, target, init="global")
        assert np.array_equal(r.transformation, align3d.register(scan, model, init="global").transformation)
        rot, trans = pose_error(r.transformation, truth)
        assert rot < 0.1 and trans < 0.01


def test_two_threads_share_one_target():
    model = surface(6000, seed=4)
    target = align3d.Target(model)
    scans = moved_scans(model, [10, 60, 100, 150])
    serial = [align3d.register(s, model, init="global").transformation for s, _ in scans]
    found = [None] * len(scans)

    def work(first):
        for i in range(first, len(scans), 2):
            found[i] = align3d.register(scans[i][0], target, init="global", threads=1).transformation

    threads = [threading.Thread(target=work, args=(k,)) for k in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(serial, found):
        assert np.array_equal(a, b)


def test_bad_targets_and_settings_raise():
    model = surface(2000, seed=5)
    with pytest.raises(align3d.DataError):
        align3d.Target(model[:5])
    with pytest.raises(align3d.FileError) as e:
        align3d.Target("no-such-model.ply")
    assert "no-such-model.ply" in str(e.value)
    with pytest.raises(ValueError):
        align3d.Target(model[:, :2])
    with pytest.raises(align3d.SettingsError):
        align3d.Target(model, normal_k=2)
    target = align3d.Target(model, normal_k=12)
    r = align3d.register(model, target)  # normal_k follows the target's
    assert np.allclose(r.transformation, np.eye(4), atol=1e-6)
    with pytest.raises(align3d.SettingsError):
        align3d.register(model, target, normal_k=20)
