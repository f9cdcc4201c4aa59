"""The PVS's stored form (partition/pvs_codec.py, pvs_coder.py): the sets and boxes come back
exactly, and a damaged pack is refused with a ValueError naming what is wrong."""
import lzma

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.partition import pvs_codec, pvs_coder
from vismobile.partition.pvs_codec import decode, decode_all, encode


def grid_boxes(rng, nx, nz, jitter):
    """(nx nz, 2, 3) boxes tiling an x-z grid of uneven steps (some split in y), in row order
    or shuffled, as the bakes' cells are."""
    xs = np.cumsum(np.r_[rng.uniform(-50, 50), rng.uniform(0.1, 9, nx)])
    zs = np.cumsum(np.r_[rng.uniform(-50, 50), rng.uniform(0.1, 9, nz)])
    i, k = np.meshgrid(np.arange(nx), np.arange(nz), indexing="ij")
    i, k = i.ravel(), k.ravel()
    lo = np.column_stack([xs[i], np.full(len(i), 1.0 / 3.0), zs[k]])
    hi = np.column_stack([xs[i + 1], np.full(len(i), 3.1), zs[k + 1]])
    boxes = np.stack([lo, hi], axis=1)
    if jitter:  # overlapping boxes too (a BSP's leaves)
        boxes = np.concatenate([boxes, boxes[:jitter] + rng.uniform(0, 1, (min(jitter, len(boxes)), 1, 3))])
    return boxes[rng.permutation(len(boxes))] if rng.integers(2) else boxes


def spatial_masks(rng, boxes, triangles, noise):
    """(V, T) bool: each triangle seen from cells within a random distance of a random point,
    flipped with probability noise (sets that are neither all nor nothing)."""
    centre = boxes.mean(axis=1)
    points = centre[rng.integers(len(boxes), size=triangles)]
    reach = rng.uniform(0, 40, triangles)
    near = np.linalg.norm(centre[:, None, :] - points[None], axis=2) < reach[None]
    return near ^ (rng.uniform(0, 1, near.shape) < noise)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), nx=st.integers(1, 12), nz=st.integers(1, 12),
       triangles=st.integers(0, 300), noise=st.sampled_from([0.0, 0.01, 0.3]),
       jitter=st.integers(0, 5))
def test_sets_and_boxes_come_back_exactly(seed, nx, nz, triangles, noise, jitter):
    rng = np.random.default_rng(seed)
    boxes = grid_boxes(rng, nx, nz, jitter)
    masks = spatial_masks(rng, boxes, triangles, noise)
    x = encode(boxes, masks)
    pvs_codec._CACHE.clear()
    got, patterns, ids = decode_all(x, triangles)
    assert got.dtype == np.float64 and np.array_equal(got, boxes)  # the very floats
    cells = len(boxes)
    sets = np.unpackbits(patterns, axis=1, count=cells)[ids].T.astype(bool) \
        if triangles else np.zeros((cells, 0), bool)
    assert np.array_equal(sets, masks)
    assert np.array_equal(pvs_codec.cell_sizes(patterns, ids, cells), masks.sum(axis=1))
    # patterns are distinct, numbered in the order triangles first use them
    assert len(np.unique(patterns, axis=0)) == len(patterns)
    assert np.array_equal(np.unique(ids, return_index=True)[1], np.sort(
        np.unique(ids, return_index=True)[1]))
    again = encode(boxes, masks)
    assert all(np.array_equal(x[k], again[k]) for k in x)  # deterministic


def test_parents_are_earlier_face_neighbours_largest_first():
    boxes = np.array([[[0, 0, 0], [1, 1, 1]], [[1, 0, 0], [2, 1, 2]], [[0, 0, 1], [1, 1, 2]],
                      [[5, 5, 5], [6, 6, 6]], [[0, 1, 0], [2, 2, 2]]], dtype=np.float64)
    par = pvs_coder.parents(boxes, 1024)
    assert par[0].tolist() == [-1, -1, -1]
    assert par[1].tolist() == [0, -1, -1]  # shares the face x = 1
    assert par[2].tolist() == [0, 1, -1]  # faces of area 1 each: the lower index first
    assert par[3].tolist() == [-1, -1, -1]  # touches nothing
    assert par[4].tolist() == [1, 0, 2]  # y = 1: areas 2, 1, 1


@pytest.fixture(scope="module")
def baked():
    rng = np.random.default_rng(5)
    boxes = grid_boxes(rng, 6, 5, 0)
    masks = spatial_masks(rng, boxes, 200, 0.05)
    return boxes, masks, encode(boxes, masks)


def _side(x):
    shape = x["pvs_shape"]
    return bytearray(lzma.decompress(x["pvs_pack"][:shape[8]].tobytes(),
                                     format=lzma.FORMAT_RAW, filters=pvs_codec.SIDE_FILTERS))


def _with_side(x, side):
    packed = lzma.compress(bytes(side), format=lzma.FORMAT_RAW, filters=pvs_codec.SIDE_FILTERS)
    shape = x["pvs_shape"].copy()
    bits = x["pvs_pack"][shape[8]:]
    shape[8] = len(packed)
    return {"pvs_shape": shape,
            "pvs_pack": np.concatenate([np.frombuffer(packed, np.uint8), bits])}


def test_a_damaged_pack_is_refused(baked):
    boxes, masks, x = baked
    cells, triangles = len(boxes), masks.shape[1]
    shape, pack = x["pvs_shape"], x["pvs_pack"]
    layout, _, count, _, size, nx, ny, nz, side_bytes, groups = (int(v) for v in shape)
    tables_at = 8 * (nx + ny + nz)
    groups_at = tables_at + 24 * cells
    refs_at = groups_at + 4 * cells
    ids_at = refs_at + 8 * count
    side = _side(x)

    def refused(extras, match, t=triangles):
        pvs_codec._CACHE.clear()
        with pytest.raises(ValueError, match=match):
            decode_all(extras, t)

    refused({**x, "pvs_shape": shape[:3]}, "another layout")
    refused(x, "triangles", triangles + 1)
    for at, value, match in ((1, 0, "view cells"), (1, pvs_codec.MAX_CELLS + 1, "view cells"),
                             (2, triangles + 1, "pattern count"), (4, 3, "id size"),
                             (5, 0, "coordinate tables"), (8, len(pack) + 1, "side stream"),
                             (2, 10 ** 9 // cells, "pattern count|too short"),
                             (9, 0, "columns"), (9, cells + 1, "columns"),
                             (9, groups - 1, "column groups")):
        bad = shape.copy()
        bad[at] = value
        refused({**x, "pvs_shape": bad}, match)
    bad = shape.copy()
    bad[8] -= 1  # the side stream's last byte counted as a pattern byte
    refused({**x, "pvs_shape": bad}, "inflate|does not start")
    refused({**x, "pvs_pack": pack[:-1]}, "ends before")
    refused({**x, "pvs_pack": np.append(pack, np.uint8(7))}, "after its patterns")
    bits = pack.copy()
    bits[side_bytes] = 1
    refused({**x, "pvs_pack": bits}, "zero byte")
    refused(_with_side(x, side[:-1]), "other than")
    refused(_with_side(x, side + b"\0"), "other than")
    refused(_with_side(x, bytes(1 << 22)), "other than")  # stops at the declared size
    for offset, raw, match in ((0, np.float64(np.nan).tobytes(), "finite and ascending"),
                               (8, np.float64(-1e300).tobytes(), "finite and ascending"),
                               (tables_at, np.uint32(nx).tobytes(), "past their coordinate"),
                               (tables_at + 12 * cells, np.uint32(nx).tobytes(), "past their"),
                               (groups_at + 4, np.uint32(2).tobytes(), "column groups"),
                               (refs_at + 4, np.uint32(2).tobytes(), "before the first"),
                               (ids_at, np.array(count, f"<u{size}").tobytes(), "outside pvs_shape")):
        edited = side.copy()
        edited[offset:offset + len(raw)] = raw
        refused(_with_side(x, edited), match)
    pvs_codec._CACHE.clear()
    assert np.array_equal(decode(x, cells, triangles)[1], decode_all(x, triangles)[2])
    with pytest.raises(ValueError, match="not 3"):
        decode(x, 3, triangles)
    assert layout == pvs_codec.LAYOUT


def test_a_pattern_bomb_is_refused_before_decoding(baked):
    # K x V bits must be codable in the stream's bytes: a tiny stream cannot claim millions
    boxes, masks, x = baked
    shape = x["pvs_shape"].copy()
    triangles = 1 << 20
    shape[2], shape[3], shape[4] = triangles, triangles, 4
    with pytest.raises(ValueError, match="too short"):
        pvs_codec._decode(shape, x["pvs_pack"], triangles)


def test_cells_with_one_set_share_a_column(baked):
    # a coarsened PVS (pvs_coarsen.py) gives groups of cells one set: the set is coded once
    boxes, masks, x = baked
    group = np.arange(len(boxes)) // 3
    shared = masks[group * 3]  # every three cells in order take the first one's set
    y = encode(boxes, shared)
    assert int(y["pvs_shape"][9]) == len(np.unique(group)) < len(boxes)
    assert len(y["pvs_pack"]) < len(x["pvs_pack"])
    pvs_codec._CACHE.clear()
    got, patterns, ids = decode_all(y, masks.shape[1])
    assert np.array_equal(got, boxes)
    assert np.array_equal(np.unpackbits(patterns, axis=1, count=len(boxes))[ids].T, shared)


def test_layout_2_still_decodes(baked):
    # layout 2 had no group map (one column per cell): the same pack without it, read alike
    boxes, masks, x = baked
    shape = x["pvs_shape"]
    cells, nx, ny, nz = int(shape[1]), *(int(v) for v in shape[5:8])
    assert int(shape[9]) == cells  # every cell its own set in this fixture
    side = _side(x)
    at = 8 * (nx + ny + nz) + 24 * cells
    assert not any(side[at:at + 4 * cells])  # the group codes: all "a new group"
    old = _with_side(x, side[:at] + side[at + 4 * cells:])
    old["pvs_shape"] = np.concatenate([[2], old["pvs_shape"][1:9]])
    pvs_codec._CACHE.clear()
    got = decode_all(old, masks.shape[1])
    pvs_codec._CACHE.clear()
    want = decode_all(x, masks.shape[1])
    assert all(np.array_equal(a, b) for a, b in zip(got, want))


def test_group_parents_sum_the_faces_between_groups():
    # cells 0-3 in a row along x (unit cubes); groups {0, 2}, {1}, {3}: group 2 ({3}) meets
    # only group 0 (through cell 2), group 1 meets group 0 on two faces
    boxes = np.array([[[i, 0, 0], [i + 1, 1, 1]] for i in range(4)], dtype=np.float64)
    near, area = pvs_coder.neighbours(boxes, 1024, pvs_coder.NEIGHBOURS)
    par = pvs_coder.group_parents(near, area, np.array([0, 1, 0, 2]), 3)
    assert par.tolist() == [[-1, -1, -1], [0, -1, -1], [0, -1, -1]]
