"""Renderer.move (issue 25): moved triangles are drawn where they stand, the others stay put."""
import numpy as np
import pytest

from vismobile.render import SENTINEL, Renderer
from vismobile.world.world import World

from .conftest import screen_quad


@pytest.mark.parametrize("fmt", ["float32", "fixed16.16"])
def test_a_moved_quad_draws_at_its_new_place_and_keeps_its_colour(camera, profile, fmt):
    profile = profile.with_(vertex_format=fmt) if fmt != profile.vertex_format else profile
    left = screen_quad(5.0, -0.9, -0.5, -0.2, 0.2)
    right = screen_quad(5.0, 0.5, 0.9, -0.2, 0.2, object_id=1)
    world = World.concatenate([left, right])
    renderer = Renderer(world, profile)
    before = renderer.render_rgb(np.arange(4), camera).copy()
    renderer.draw(np.arange(4), camera, kind="item")
    ids = renderer.read_ids()
    assert set(np.unique(ids[:, 150:])) - {SENTINEL} == {2, 3}
    moved = world.corners[:2] + [0.0, 0.0, 1.0]  # the left quad 1 m nearer...
    moved[:, :, 0] += 1.2  # ...and across to the middle
    assert renderer.move([0, 1], moved) == 1  # one run of consecutive ids: one write
    renderer.draw(np.arange(4), camera, kind="item")
    ids = renderer.read_ids()
    columns = np.flatnonzero((ids == 0).any(axis=0) | (ids == 1).any(axis=0))
    assert columns.min() > 60 and columns.max() < 180  # no longer at the left edge
    assert not np.isin(ids[:, :40], [0, 1]).any()
    assert set(np.unique(ids[:, 200:])) - {SENTINEL} == {2, 3}  # the other quad stays
    after = renderer.render_rgb(np.arange(4), camera)
    colour = lambda image, c: image[160, c]  # noqa: E731
    assert (colour(after, 120) == colour(before, 20)).all()  # the same object colour
