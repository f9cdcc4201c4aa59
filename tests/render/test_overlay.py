import numpy as np

from vismobile.render.overlay import box_lines


def test_box_lines_are_the_twelve_edges():
    lines = box_lines([[[0, 0, 0], [1, 2, 3]]]).reshape(-1, 2, 3)
    assert lines.shape == (12, 2, 3)
    lengths = np.sort(np.linalg.norm(lines[:, 1] - lines[:, 0], axis=1))
    assert np.allclose(lengths, [1] * 4 + [2] * 4 + [3] * 4)
    # each edge changes exactly one coordinate
    assert ((lines[:, 1] != lines[:, 0]).sum(axis=1) == 1).all()
    assert box_lines(np.zeros((0, 2, 3))).shape == (0, 3)
