"""Tables shared between cullers of one world or partition (culling/shared.py): computed once,
never written by a culler, dropped with their owner."""
import gc

import numpy as np

from vismobile.culling import Culler, shared
from vismobile.partition import partition


def test_a_table_is_computed_once_per_owner_and_dropped_with_it(kit):
    class Owner:
        pass

    owner, calls = Owner(), []
    first = shared.per_object(owner, "t", lambda: calls.append(1) or np.arange(3))
    assert shared.per_object(owner, "t", lambda: calls.append(1) or np.arange(3)) is first
    assert len(calls) == 1
    assert shared.per_object(owner, "u", lambda: 7) == 7  # another name: its own table
    key = id(owner)
    del owner
    gc.collect()
    assert key not in shared._TABLES
    assert shared.per_object((1, 2), "t", lambda: 5) == 5  # no weak reference: not kept


def test_cullers_sharing_tables_cull_alike_when_interleaved(kit):
    # Culler a culls every camera; then b and c (made after a's culls, sharing its tables) cull
    # them in turn, camera by camera: if a stage wrote into a shared table, or shared scratch,
    # they would differ from a.
    part = partition(kit.world("w1"), "octree", depth=4)
    stages = "vfc,cone,occlusion,tbfc"
    a = Culler(part, stages)
    cameras = kit.random_cameras(part, 12, seed=3)
    first = [a.cull(camera).triangles for camera in cameras]
    b, c = Culler(part, stages), Culler(part, stages)
    occ_a, occ_b = (next(s for s in x.stages if s.name == "occlusion") for x in (a, b))
    cone_a, cone_b = (next(s for s in x.stages if s.name == "cone") for x in (a, b))
    assert occ_b.partner is occ_a.partner and cone_b.apex is cone_a.apex
    assert occ_b.stamp is not occ_a.stamp  # scratch stays per culler
    for camera, expect in zip(cameras, first):
        assert np.array_equal(b.cull(camera).triangles, expect)
        assert np.array_equal(c.cull(camera).triangles, expect)
