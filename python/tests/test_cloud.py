"""PointCloud (numpy views, validation) and the file readers and writers."""

import gc

import numpy as np
import pytest

import align3d
from conftest import rigid


def test_points_are_a_view_of_the_cloud_not_a_copy():
    cloud = align3d.PointCloud(np.arange(12.0).reshape(4, 3))
    view = cloud.points
    assert view.dtype == np.float64 and view.shape == (4, 3) and view.flags.c_contiguous
    assert not view.flags.owndata
    assert np.shares_memory(view, cloud.points)  # two accesses, one storage
    view[2, 1] = -5.0
    assert cloud.points[2, 1] == -5.0  # a write through a view is the cloud's


def test_a_view_keeps_its_cloud_alive():
    view = align3d.PointCloud(np.full((1000, 3), 7.0)).points
    gc.collect()
    np.testing.assert_array_equal(view, 7.0)


def test_the_input_array_is_copied_once_into_the_cloud():
    points = np.zeros((5, 3))
    cloud = align3d.PointCloud(points)
    points[0, 0] = 1.0
    assert cloud.points[0, 0] == 0.0
    assert not np.shares_memory(points, cloud.points)


def test_assigning_points_writes_in_place_so_old_views_see_it():
    cloud = align3d.PointCloud(np.zeros((3, 3)))
    view = cloud.points
    cloud.points = np.ones((3, 3))
    np.testing.assert_array_equal(view, 1.0)
    with pytest.raises(ValueError, match=r"4 rows for a cloud of 3 points"):
        cloud.points = np.ones((4, 3))


def test_integer_and_float32_arrays_become_float64():
    cloud = align3d.PointCloud(np.arange(9, dtype=np.int32).reshape(3, 3))
    assert cloud.points.dtype == np.float64
    np.testing.assert_array_equal(cloud.points, np.arange(9).reshape(3, 3))
    cloud = align3d.PointCloud(np.full((2, 3), 0.5, dtype=np.float32))
    np.testing.assert_array_equal(cloud.points, 0.5)
    cloud = align3d.PointCloud([[1, 2, 3], [4, 5, 6]])  # nested lists too
    assert len(cloud) == 2


def test_normals_are_normalised_views():
    cloud = align3d.PointCloud(np.zeros((2, 3)), normals=[[0, 0, 2], [3, 4, 0]])
    assert cloud.has_normals
    np.testing.assert_allclose(cloud.normals, [[0, 0, 1], [0.6, 0.8, 0]])
    assert np.shares_memory(cloud.normals, cloud.normals)
    bare = align3d.PointCloud(np.zeros((2, 3)))
    assert bare.normals is None and not bare.has_normals
    bare.normals = [[1, 0, 0], [0, 1, 0]]
    np.testing.assert_array_equal(bare.normals, [[1, 0, 0], [0, 1, 0]])


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((4, 2)),
        np.zeros(3),
        np.zeros((2, 3, 1)),
        np.zeros((4, 3), dtype=complex),
        np.array([[1, 2, 3], [4, 5, "x"]], dtype=object),
        np.zeros((4, 3), dtype=bool),
        np.array([["1", "2", "3"]]),
        "not an array",
    ],
    ids=["Nx2", "1-D", "3-D", "complex", "object", "bool", "strings", "str"],
)
def test_wrong_shape_or_dtype_is_a_value_error_naming_the_argument(bad):
    with pytest.raises(ValueError, match=r"^points: expected") as raised:
        align3d.PointCloud(bad)
    assert not isinstance(raised.value, align3d.Error)  # a plain ValueError: the array's fault


def test_nan_or_inf_is_the_librarys_data_error():
    points = np.zeros((4, 3))
    points[2, 1] = np.nan
    with pytest.raises(align3d.DataError, match=r"point 2 has a NaN or Inf coordinate"):
        align3d.PointCloud(points)
    points[2, 1] = np.inf
    with pytest.raises(ValueError):  # a DataError is a ValueError too
        align3d.PointCloud(points)
    with pytest.raises(align3d.DataError, match=r"row 1 has no direction"):
        align3d.PointCloud(np.zeros((2, 3)), normals=[[0, 0, 1], [0, 0, 0]])
    with pytest.raises(ValueError, match=r"normals: 1 rows for a cloud of 2 points"):
        align3d.PointCloud(np.zeros((2, 3)), normals=[[0, 0, 1]])


def test_len_and_repr():
    cloud = align3d.PointCloud(np.zeros((7, 3)))
    assert len(cloud) == 7
    assert repr(cloud) == "<align3d.PointCloud of 7 points>"


def test_transformed_moves_points_and_turns_normals():
    rng = np.random.default_rng(3)
    points, normals = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    T = rigid([1, -2, 0.5], 33.0, [1.0, 2.0, -3.0])
    moved = align3d.PointCloud(points, normals).transformed(T)
    np.testing.assert_allclose(moved.points, points @ T[:3, :3].T + T[:3, 3], atol=1e-12)
    unit = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(moved.normals, unit @ T[:3, :3].T, atol=1e-12)
    scaled = T.copy()
    scaled[:3, :3] *= 2
    with pytest.raises(align3d.SettingsError, match=r"not orthonormal"):
        moved.transformed(scaled)
    with pytest.raises(ValueError, match=r"4x4"):
        moved.transformed(np.eye(3))


def test_copy_owns_its_data():
    cloud = align3d.PointCloud(np.zeros((3, 3)))
    other = cloud.copy()
    other.points[0, 0] = 1
    assert cloud.points[0, 0] == 0


@pytest.mark.parametrize(
    "name, encoding, has_normals",
    [
        ("c.ply", None, True),
        ("c.ply", "ascii", True),
        ("c.ply", "binary_big_endian", True),
        ("c.pcd", None, True),
        ("c.pcd", "ascii", True),
        ("c.pcd", "binary_compressed", True),
        ("c.xyz", None, False),
        ("c.txt", None, False),
        ("c.csv", None, False),
    ],
)
def test_write_then_read_gives_the_cloud_back(tmp_path, name, encoding, has_normals):
    rng = np.random.default_rng(5)
    points = rng.uniform(-100, 100, size=(200, 3))
    normals = rng.normal(size=(200, 3))
    align3d.write_point_cloud(tmp_path / name, align3d.PointCloud(points, normals),
                              encoding=encoding)
    back = align3d.read_point_cloud(tmp_path / name)
    assert len(back) == 200
    np.testing.assert_allclose(back.points, points, rtol=1e-6)  # float32 in PLY and PCD
    assert back.has_normals == has_normals
    if has_normals:
        unit = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        np.testing.assert_allclose(back.normals, unit, atol=1e-6)


def test_a_plain_array_can_be_written(tmp_path):
    align3d.write_point_cloud(tmp_path / "a.xyz", [[1, 2, 3], [4, 5, 6], [7, 8, 9]])
    np.testing.assert_array_equal(align3d.read_point_cloud(tmp_path / "a.xyz").points,
                                  [[1, 2, 3], [4, 5, 6], [7, 8, 9]])


def test_dropped_nan_points_are_a_warning(tmp_path):
    (tmp_path / "n.xyz").write_text("1 2 3\nnan 0 0\n4 5 6\n")
    with pytest.warns(align3d.AlignWarning, match=r"dropped 1 points with NaN"):
        cloud = align3d.read_point_cloud(tmp_path / "n.xyz")
    assert len(cloud) == 2


def test_writing_errors(tmp_path):
    cloud = align3d.PointCloud(np.zeros((3, 3)))
    with pytest.raises(align3d.FileError) as raised:
        align3d.write_point_cloud(tmp_path / "c.obj", cloud)
    assert raised.value.path == str(tmp_path / "c.obj") and raised.value.code == 5
    with pytest.raises(align3d.FileError, match=r"cannot write") as raised:
        align3d.write_point_cloud(tmp_path / "missing" / "c.ply", cloud)
    assert raised.value.path == str(tmp_path / "missing" / "c.ply")
    with pytest.raises(align3d.SettingsError, match=r"text and have no encoding"):
        align3d.write_point_cloud(tmp_path / "c.xyz", cloud, encoding="ascii")
    with pytest.raises(align3d.SettingsError, match=r"PLY has no encoding 'gzip'"):
        align3d.write_point_cloud(tmp_path / "c.ply", cloud, encoding="gzip")
    assert list(tmp_path.iterdir()) == []  # nothing written, not even a temporary


def test_matrix_files_round_trip_exactly(tmp_path):
    T = rigid([0.3, 0.2, -1], 71.0, [12.5, -3.25, 1e-3])
    align3d.write_matrix(tmp_path / "T.txt", T)
    back = align3d.read_matrix(tmp_path / "T.txt")
    assert back.shape == (4, 4)
    np.testing.assert_allclose(back, T, rtol=0, atol=1e-12)  # R snapped to a rotation
    np.testing.assert_array_equal(back[:3, 3], T[:3, 3])
    with pytest.raises(align3d.SettingsError, match=r"determinant -1"):
        align3d.write_matrix(tmp_path / "R.txt", np.diag([1.0, 1.0, -1.0, 1.0]))
