# dsnake.Image (a zero-copy numpy view in SimpleITK's [z, y, x] order), read_image / write_image,
# read_mesh / write_mesh, and the checks on the arrays handed in.
import numpy as np
import pytest

import dsnake


def test_the_array_is_a_view_in_z_y_x_order():
    voxels = np.arange(4 * 3 * 2, dtype=np.float32).reshape(4, 3, 2)  # [z, y, x]
    image = dsnake.Image(voxels, spacing=(0.5, 1.0, 2.0), origin=(1, 2, 3))
    view = image.array
    assert view.shape == (4, 3, 2) and view.dtype == np.float32
    np.testing.assert_array_equal(view, voxels)
    assert np.shares_memory(view, image.array)  # the same voxels every time
    view[1, 2, 1] = -7
    assert image.array[1, 2, 1] == -7
    assert image.spacing == [0.5, 1.0, 2.0] and image.origin == [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(image.direction, np.eye(3))
    assert image.dimension == 3


def test_a_view_keeps_its_image_alive():
    view = dsnake.Image(np.ones((5, 6))).array
    assert view.shape == (5, 6) and view.sum() == 30


def test_write_and_read_an_image_keeps_voxels_and_geometry(tmp_path):
    # An oblique grid: a rotation by 30 degrees (one by 90 would come back as the axes reordered,
    # as read_image makes a grid as near axis-aligned as it can, framework/io/image_io.h).
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    rotation = np.array([[c, -s], [s, c]])
    image = dsnake.Image(np.random.default_rng(1).random((7, 9)), spacing=(0.7, 1.3), origin=(-4, 5),
                         direction=rotation)
    path = tmp_path / "image.nii.gz"
    dsnake.write_image(image, str(path))
    back = dsnake.read_image(str(path))
    np.testing.assert_allclose(back.array, image.array, rtol=0, atol=1e-6)
    np.testing.assert_allclose(back.spacing, image.spacing, atol=1e-6)
    np.testing.assert_allclose(back.origin, image.origin, atol=1e-6)
    np.testing.assert_allclose(back.direction, rotation, atol=1e-6)


def test_write_and_read_a_mesh(tmp_path):
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    dsnake.write_mesh(str(tmp_path / "t.ply"), vertices, faces)
    v, f = dsnake.read_mesh(str(tmp_path / "t.ply"))
    np.testing.assert_array_equal(v, vertices)
    np.testing.assert_array_equal(f, faces)


def test_write_and_read_a_contour(tmp_path):
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    contour = np.stack([np.cos(angles), np.sin(angles)], axis=1) * 10
    dsnake.write_mesh(str(tmp_path / "c.txt"), contour)
    v, f = dsnake.read_mesh(str(tmp_path / "c.txt"), dimension=2)
    assert f is None
    np.testing.assert_array_equal(v, contour)


@pytest.mark.parametrize("array, match", [
    (np.zeros((4, 4), dtype=np.complex128), "dtype"),
    (np.array([["a", "b"], ["c", "d"]]), "dtype"),
    (np.zeros(5), "dimensions"),
    (np.zeros((2, 2, 2, 2)), "dimensions"),
    (np.zeros((6, 6))[:, ::2], "C-contiguous"),
    (np.full((3, 3), np.nan), "NaN"),
    ([[1.0, 2.0], [3.0, 4.0]], "numpy array"),
])
def test_bad_arrays_name_the_argument(array, match):
    with pytest.raises(dsnake.InputError, match="argument 'array'.*" + match):
        dsnake.Image(array)


@pytest.mark.parametrize("kwargs, argument", [
    ({"spacing": (1, 0)}, "spacing"),
    ({"spacing": (1, 2, 3)}, "spacing"),
    ({"origin": (np.nan, 0)}, "origin"),
    ({"direction": [[1, 1], [0, 1]]}, "direction"),
])
def test_bad_geometry_names_the_argument(kwargs, argument):
    with pytest.raises(dsnake.InputError, match=argument):
        dsnake.Image(np.zeros((3, 3)), **kwargs)


@pytest.mark.parametrize("vertices, faces, match", [
    (np.zeros((4, 3), dtype=np.float32), np.zeros((1, 3), dtype=int), "vertices.*float64"),
    (np.zeros((4, 2)), np.zeros((1, 3), dtype=int), "vertices.*shape"),
    (np.zeros((4, 3)), np.array([[0, 1, 9]]), "faces.*vertex 9"),
    (np.zeros((4, 3)), np.zeros((1, 3)), "faces.*integer"),
])
def test_bad_meshes_name_the_argument(tmp_path, vertices, faces, match):
    with pytest.raises(dsnake.InputError, match=match):
        dsnake.write_mesh(str(tmp_path / "m.ply"), vertices, faces)


def test_a_missing_image_file():
    with pytest.raises(dsnake.InputError, match="nosuch.nii.gz"):
        dsnake.read_image("/no/nosuch.nii.gz")
