import numpy as np
import pytest

from vismobile.errors import WorldError
from vismobile.terrain.heightmap import Heightmap, grid_exponent, quantize
from vismobile.terrain.mesh import grid_mesh, grid_triangles


def test_grid_exponent():
    assert [grid_exponent(n) for n in (3, 5, 129, 4097)] == [1, 2, 7, 12]
    assert [grid_exponent(n) for n in (1, 2, 4, 128, 130)] == [None] * 5


def test_rejects_non_grid_shapes():
    with pytest.raises(ValueError):
        Heightmap(np.zeros((4, 4)))
    with pytest.raises(ValueError):
        Heightmap(np.zeros((5, 9)))
    with pytest.raises(WorldError, match="2\\^n\\+1"):
        quantize(np.zeros((6, 6)), path="x.npy")
    with pytest.raises(WorldError, match="no valid sample"):
        quantize(np.full((5, 5), np.nan), path="x.npy")


def test_quantize_keeps_range_within_half_a_step():
    rng = np.random.default_rng(1)
    heights = rng.uniform(-30, 70, (17, 17))
    hm = quantize(heights, spacing=2.0)
    assert hm.samples.dtype == np.uint16 and hm.samples.max() == 65535 and hm.samples.min() == 0
    assert np.abs(hm.heights - heights).max() <= hm.z_scale / 2 + 1e-4
    assert hm.extent == 32.0


def test_height_at_matches_mesh_triangles():
    """height_at interpolates on the mesh's own triangles: at a triangle's centroid it is the
    mean of the three corner heights, for both triangles of every cell."""
    rng = np.random.default_rng(2)
    hm = quantize(rng.uniform(0, 10, (9, 9)), spacing=1.5)
    vertices, triangles = grid_mesh(hm)
    centroids = vertices[triangles].mean(axis=1)
    got = hm.height_at(centroids[:, 0], centroids[:, 2])
    assert np.allclose(got, centroids[:, 1], atol=1e-9)
    # Samples themselves come back exactly.
    assert np.allclose(hm.height_at(vertices[:, 0], vertices[:, 2]), vertices[:, 1])


def test_grid_triangles_face_up_and_cover_the_square():
    vertices, triangles = grid_mesh(quantize(np.zeros((5, 5))), stride=2)
    corners = vertices[triangles]
    normal_y = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])[:, 1]
    assert len(triangles) == 8 and (normal_y > 0).all()
    assert np.isclose(0.5 * normal_y.sum(), 16.0)
    assert grid_triangles(1).tolist() == [[0, 3, 1], [0, 2, 3]]
    with pytest.raises(ValueError):
        grid_mesh(quantize(np.zeros((5, 5))), stride=3)


def test_nan_samples_are_holes_filled_from_their_nearest_valid_neighbour():
    from vismobile.terrain.heightmap import fill_holes

    h = np.arange(25.0).reshape(5, 5)
    h[1, 1:4] = np.nan
    h[3] = np.nan
    hm = quantize(h, path="x.npy")
    assert hm.holes and hm.valid.sum() == 25 - 3 - 5
    filled = fill_holes(h, ~np.isnan(h))
    assert filled[1, 1] == h[1, 0] and filled[1, 3] == h[1, 4]  # nearer side along the row
    assert np.array_equal(filled[3], h[2])  # a row with none: from the column (ties: earlier)
    assert np.allclose(hm.heights[~np.isnan(h)], h[~np.isnan(h)], atol=24 / 65535)
    assert quantize(np.where(np.isnan(h), 0.0, h)).digest() != hm.digest()
