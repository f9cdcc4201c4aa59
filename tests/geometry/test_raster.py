"""Edge pieces split at T-junctions (geometry/raster.py), which the occlusion rasteriser pairs
with their reverse (culling/hiz.py; its contract is tested in tests/culling/test_hiz.py)."""
import numpy as np

from vismobile.geometry.raster import split_edges


def test_split_edges_splits_at_t_junctions_and_keeps_winding():
    pts = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 0, 0], [1, -1, 0]])
    tri = np.array([[0, 1, 2], [0, 4, 3]])  # corner 3 lies on the first triangle's edge 0 -> 1
    owner, a, b = split_edges(pts, tri)
    first = [(int(x), int(y)) for t, x, y in zip(owner, a, b) if t == 0]
    assert first == [(0, 3), (3, 1), (1, 2), (2, 0)]
    assert [(int(x), int(y)) for t, x, y in zip(owner, a, b) if t == 1] == [(0, 4), (4, 3), (3, 0)]
