"""pvs_pool.fan_out: a bake's parts over processes come back in the items' order."""
import numpy as np

from vismobile.partition.pvs_pool import fan_out, strided_parts


def _square_plus(offset, part, scale):
    """A task: one result per item of part (its id scaled, plus the shared offset)."""
    return [offset[0] + scale * int(i) for i in part]


def test_strided_parts_cover_every_item_once_in_turn():
    parts = strided_parts(10, 3)
    assert [p.tolist() for p in parts] == [[0, 3, 6, 9], [1, 4, 7], [2, 5, 8]]
    assert [p.tolist() for p in strided_parts(2, 16)] == [[0], [1]]


def test_fan_out_over_processes_keeps_the_items_order():
    items = np.arange(37)[::-1].copy()  # not sorted: order comes from the items, not the ids
    seen = []
    serial = fan_out(_square_plus, (np.array([5]),), items, (3,))
    spread = fan_out(_square_plus, (np.array([5]),), items, (3,), jobs=2,
                     progress=lambda done, total: seen.append((done, total)))
    assert serial == [5 + 3 * int(i) for i in items]
    assert spread == serial
    assert seen[-1] == (37, 37) and all(a[0] < b[0] for a, b in zip(seen, seen[1:]))
    listed = fan_out(_square_plus, (np.array([1]),), list(items), (2,), jobs=2)
    assert listed == [1 + 2 * int(i) for i in items]
