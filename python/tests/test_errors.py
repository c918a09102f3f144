"""Every hostile file is an exception naming it, never a crash: tests/data/hostile (the fuzzers'
findings and the catalogue of malformed files, manifest.tsv: the same rows the CLI is checked
with in tests/hostile_test.cpp) and the fuzzers' seed corpus, fuzz/corpus."""


import numpy as np
import pytest

import align3d
from conftest import REPO

HOSTILE = REPO / "tests" / "data" / "hostile"
CORPUS = REPO / "fuzz" / "corpus"


def manifest():
    rows = []
    for line in (HOSTILE / "manifest.tsv").read_text().splitlines():
        if line and not line.startswith("#"):
            file, command, code, phrase = line.split("\t")
            rows.append(pytest.param(file, command, int(code), phrase, id=f"{file}-{command}"))
    return rows


def box_corner():
    """Three faces of a box around one corner, 300 points: any file can be paired with it."""
    u, v = np.meshgrid(np.arange(10) * 3.0, np.arange(10) * 2.0)
    u, v, o = u.ravel(), v.ravel(), np.zeros(100)
    return np.vstack([np.column_stack(c) for c in ((u, v, o), (u, o, v), (o, u, v))])


@pytest.mark.parametrize("file, command, code, phrase", manifest())
def test_a_hostile_file_is_an_exception_naming_it(file, command, code, phrase, tmp_path):
    path = str(HOSTILE / file)
    good = box_corner()
    call = {
        "register": lambda: align3d.register(path, good),
        "target": lambda: align3d.register(good, path),
        "init": lambda: align3d.register(good, good, init=path),
        "ground-truth": lambda: align3d.register(good, good, ground_truth=path),
        "rectify": lambda: align3d.rectify(path),
        "convert-mesh": lambda: align3d.convert(path, tmp_path / "mesh.ply"),
    }[command]
    expected = {3: align3d.FileError, 4: align3d.DataError}[code]
    with pytest.raises(expected) as raised:
        call()
    error = raised.value
    if "built with OpenCASCADE" in str(error):  # every STEP and IGES file without it (README)
        pytest.skip("align3d built without OpenCASCADE (ALIGN3D_OCCT)")
    assert error.code == code
    assert path in str(error), "the message does not name the file"
    assert phrase in str(error)
    if expected is align3d.FileError:
        assert error.path == path and isinstance(error, OSError)


def test_a_missing_file_is_a_file_error_naming_it(tmp_path):
    missing = tmp_path / "no such scan.ply"
    for call in (lambda: align3d.read_point_cloud(missing),
                 lambda: align3d.register(missing, box_corner()),
                 lambda: align3d.rectify(missing),
                 lambda: align3d.read_matrix(missing),
                 lambda: align3d.convert(missing, tmp_path / "out.pcd")):
        with pytest.raises(align3d.FileError) as raised:
            call()
        assert raised.value.path == str(missing) and raised.value.filename == str(missing)
        assert str(raised.value).startswith(f"{missing}: ")
        assert raised.value.code == 3
    with pytest.raises(OSError):  # as Python's own file errors
        align3d.read_point_cloud(missing)


@pytest.mark.filterwarnings("ignore::align3d.AlignWarning")  # seeds with NaN points: dropped
@pytest.mark.parametrize(
    "seed", sorted(p for p in CORPUS.glob("*/*") if p.parent.name != "matrix"), ids=lambda p: p.name
)
def test_every_fuzz_seed_reads_or_names_itself(seed):
    try:
        cloud = align3d.read_point_cloud(seed)
    except align3d.FileError as e:
        assert e.path == str(seed) and str(seed) in str(e)
    else:
        assert len(cloud) > 0 and np.isfinite(cloud.points).all()


@pytest.mark.parametrize("seed", sorted(CORPUS.glob("matrix/*")), ids=lambda p: p.name)
def test_every_matrix_seed_reads_as_a_rigid_transform(seed):
    T = align3d.read_matrix(seed)
    np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-9)
    np.testing.assert_array_equal(T[3], [0, 0, 0, 1])


def test_the_error_classes():
    assert issubclass(align3d.FileError, align3d.Error) and issubclass(align3d.FileError, OSError)
    assert issubclass(align3d.DataError, ValueError)
    assert issubclass(align3d.SettingsError, ValueError)
    for cls in (align3d.NoSolutionError, align3d.StrictError):
        assert issubclass(cls, align3d.Error)
    assert issubclass(align3d.AlignWarning, UserWarning)
