"""The distinct gather (culling/gather.py) against np.unique of the concatenated references: the
two-level bitmap kernels on random ranges sharing triangles, the (word, mask) pairs, the
per-level lists of a real octree (each subtree's triangles, each at least once), first depths
against their definition, the output pool, and the walk's whole_below superset."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler, gather
from vismobile.culling.gather import (Bitmap, choose_levels, count_marked, extract_marked,
                                      first_depths, level_groups, mark_nodes)
from vismobile.culling.tree import Tree


def runs_of(ids):
    return int(len(ids) and 1 + np.count_nonzero(np.diff(ids) != 1))


def gather_ranges(refs, starts, ends, nodes, count):
    """Sorted distinct ids of refs[starts[n]:ends[n]] for n in nodes, each reference its own
    pair (ranges may overlap and ids need not ascend)."""
    b = Bitmap(count)
    refs = np.asarray(refs, dtype=np.int64)
    words = (refs >> 6).astype(np.uint32)
    masks = np.uint64(1) << (refs & 63).astype(np.uint64)
    span = np.stack([starts, ends], axis=1)
    ntops = mark_nodes(words, masks, span, nodes, b.bits, b.summary, b.tops,
                       b.node_ranges(len(nodes)))
    out = np.full(count_marked(b.bits, b.summary, b.tops, ntops), -1, dtype=np.int64)
    runs = extract_marked(b.bits, b.summary, b.tops, ntops, out)
    assert not b.bits.any() and not b.summary.any()  # both levels left clear for the next frame
    return out, runs


def decode(words, masks):
    """(ids of each pair's mask, concatenated in pair order)."""
    bits = (masks[:, None] >> np.arange(64, dtype=np.uint64)) & np.uint64(1)
    pair, bit = np.nonzero(bits)
    return words[pair].astype(np.int64) * 64 + bit


@pytest.mark.parametrize("seed", range(4))
def test_bitmap_gather_is_sorted_unique_of_the_ranges(seed):
    rng = np.random.default_rng(seed)
    count = int(rng.choice([100, 5000, 300_000]))  # one, a few and many summary words
    refs = rng.integers(0, count, 20_000).astype(np.int32)
    refs[5000:9000] = np.arange(4000) + count // 3 if count > 9000 else refs[5000:9000]  # dense
    starts = np.sort(rng.integers(0, len(refs), 60)).astype(np.int64)
    ends = np.minimum(starts + rng.integers(0, 3000, 60), len(refs)).astype(np.int64)
    nodes = rng.choice(60, 40, replace=False).astype(np.int64)  # ranges overlap: shared ids
    expect = np.unique(np.concatenate([refs[starts[k]:ends[k]] for k in nodes]))
    ids, runs = gather_ranges(refs, starts, ends, nodes, count)
    assert np.array_equal(ids, expect)
    assert runs == runs_of(expect)


def test_level_groups_pair_each_segments_sorted_references_by_word():
    refs = np.array([64, 5, 63, 1, 70, 4, 3, 200, 7], dtype=np.int32)  # not ascending
    fd = np.array([1, 2, 0, 0, 0, 3, 0, 0, 1], dtype=np.uint8)
    leaf_starts = np.array([0, 5, 5, 8], np.int64)  # an empty segment at 5
    none = np.zeros(0, np.int32)
    for level, expect in ((255, [[1, 5, 63], [64, 70], [3, 4], [200], [7]]),
                          (1, [[1, 63], [64, 70], [3], [200], [7]]),
                          (0, [[1, 63], [70], [3], [200]])):
        offsets = level_groups(refs, fd, level, leaf_starts, none, none)
        words = np.empty(offsets[-1], np.int32)
        masks = np.empty(offsets[-1], np.uint64)
        assert np.array_equal(level_groups(refs, fd, level, leaf_starts, words, masks), offsets)
        pairs = [decode(words[k:k + 1], masks[k:k + 1]).tolist() for k in range(len(words))]
        assert pairs == expect
        # a segment's pairs start at its offset: segment 1 is empty, segment 2 starts at ref 5
        assert decode(words[offsets[2]:offsets[3]], masks[offsets[2]:offsets[3]]).tolist() == \
            sorted(t for t, d in zip(refs[5:8].tolist(), fd[5:8]) if d <= level)


def test_bitmap_gather_of_no_nodes_is_empty():
    refs = np.arange(10, dtype=np.int32)
    ids, runs = gather_ranges(refs, np.zeros(1, np.int64), np.full(1, 10), np.zeros(0, np.int64),
                              10)
    assert len(ids) == 0 and runs == 0


def test_first_depths_follow_their_definition(w1_octree):
    tree = Tree(w1_octree)
    p = w1_octree
    depth = p.node_levels().astype(np.int64)
    parent = np.full(tree.node_count, -1, np.int64)
    for node in np.flatnonzero(tree.child_count):
        parent[tree.first_child[node]:tree.first_child[node] + tree.child_count[node]] = node
    leaves = tree.leaf_order[tree.nonempty[tree.leaf_order]]
    refs = np.asarray(tree.tri_refs)
    fd = first_depths(refs, leaves, parent, depth, tree.ref_start, tree.ref_end,
                      np.full(p.world.triangle_count, -1, np.int64))
    rng = np.random.default_rng(1)
    for leaf in rng.choice(leaves, 40, replace=False):
        chain = [leaf]
        while parent[chain[-1]] >= 0:
            chain.append(parent[chain[-1]])
        for r in range(tree.ref_start[leaf], tree.ref_end[leaf]):
            # the shallowest ancestor in whose range r is the triangle's first reference
            first = [a for a in chain if refs[tree.ref_start[a]:r].tolist().count(refs[r]) == 0]
            assert fd[r] == min(depth[a] for a in first)
    assert (fd == 0).sum() == len(np.unique(refs))  # each triangle's first reference overall


def test_level_pairs_hold_each_subtree_triangle(w1_octree, monkeypatch):
    monkeypatch.setattr(gather, "KEEP_RATIO", 1.0)  # keep every level: all lists are checked
    monkeypatch.setattr(gather, "MAX_COARSE", 100.0)
    tree = Tree(w1_octree)
    g = tree.groups
    assert g.levels == list(range(w1_octree.depth - 1, -1, -1))
    levels = w1_octree.node_levels()
    fewer = 0
    for node in range(tree.node_count):
        listed = decode(g.words[g.start[node]:g.end[node]], g.masks[g.start[node]:g.end[node]])
        subtree = np.unique(tree.refs([node]))
        assert np.array_equal(np.unique(listed), subtree)
        if levels[node] < w1_octree.depth:  # its own level's list: each triangle once
            assert len(listed) == len(subtree)
        fewer += g.end[node] - g.start[node] < tree.ref_end[node] - tree.ref_start[node]
    assert fewer  # pairs are fewer than references


@pytest.mark.parametrize("keep", [0.75, 1.0])
def test_tree_gather_equals_unique_of_the_subtrees(w1_octree, monkeypatch, keep):
    monkeypatch.setattr(gather, "KEEP_RATIO", keep)
    monkeypatch.setattr(gather, "MAX_COARSE", 100.0)
    tree = Tree(w1_octree)
    rng = np.random.default_rng(7)
    for size in (1, 5, 40, 200):
        nodes = rng.choice(tree.node_count, size, replace=False)  # nested subtrees too
        ids, runs = tree.gather(nodes)
        expect = np.unique(tree.refs(nodes))
        assert np.array_equal(ids, expect) and ids.dtype == np.int64
        assert runs == runs_of(expect)


def test_choose_levels_keeps_levels_that_save_references():
    # counts[c]: references of first depth <= c for c = 0..3; the leaves hold 100
    assert choose_levels(np.array([40, 50, 60, 90]), 100) == [2, 0]  # 90 > 0.75 * 100
    assert choose_levels(np.array([10, 20, 70, 74]), 100) == [3, 1, 0]
    assert choose_levels(np.array([40, 55, 74]), 100) == [2, 1]  # 40 more would pass 1.5x
    assert choose_levels(np.array([100, 100]), 100) == []


def test_held_results_are_not_overwritten(w1_octree):
    tree = Tree(w1_octree)
    first, _ = tree.gather(np.array([0]))
    kept = first.copy()
    for _ in range(4):  # the pool must not hand out a buffer a live result views
        other, _ = tree.gather(np.array([tree.first_child[0]]))
    assert np.array_equal(first, kept)
    del first, other
    again, _ = tree.gather(np.array([0]))
    assert np.array_equal(again, kept)


def test_whole_below_sends_a_superset_from_fewer_nodes(w1_octree):
    tree = Tree(w1_octree)
    world = w1_octree.world
    rng = np.random.default_rng(5)
    low, high = world.extent
    fewer = 0
    for _ in range(8):
        cam = Camera(rng.uniform(low, high), yaw=rng.uniform(0, 360), pitch=rng.uniform(-40, 40),
                     aspect=0.75)
        planes = cam.frustum_planes()[None]
        root = np.zeros(1, np.int64)
        exact, visited, *_, straddling, _ = tree.walk(root, root, planes, -1)
        assert straddling == 0
        coarse, fewer_visits, *_, straddling, _ = tree.walk(root, root, planes, 10 ** 9)
        assert np.all(np.isin(tree.distinct_refs(exact), tree.distinct_refs(coarse)))
        assert fewer_visits <= visited and straddling <= len(coarse)
        fewer += fewer_visits < visited
    assert fewer  # it does save nodes


def test_vfc_counts_nodes_accepted_across_a_plane(w1_octree):
    cam = Camera((5.0, 1.7, 5.0), yaw=30.0, pitch=0.0, aspect=0.75)
    exact = Culler(w1_octree, "vfc", vfc={"whole_below": -1}).cull(cam)
    whole = Culler(w1_octree, "vfc", vfc={"whole_below": 10 ** 9}).cull(cam)
    assert "vfc.nodes_straddling" not in exact.stats
    assert whole.stats["vfc.nodes_straddling"] > 0
    assert whole.stats["nodes_visited"] < exact.stats["nodes_visited"]
    assert np.all(np.isin(exact.triangles, whole.triangles))
    with pytest.raises(ValueError, match="whole_below"):
        Culler(w1_octree, "vfc", vfc={"whole_below": -2})


def test_vfc_covers_only_where_no_later_stage_tests_its_nodes(w1_octree):
    cam = Camera((5.0, 1.7, 5.0), yaw=30.0, pitch=0.0, aspect=0.75)
    for stages in ("vfc", "vfc,cbfc", "vfc,tbfc", "vfc,cone", "vfc,bfc,cbfc,cone"):
        walked = Culler(w1_octree, stages, vfc={"cover": False}).cull(cam)
        covered = Culler(w1_octree, stages).cull(cam)
        assert np.array_equal(walked.triangles, covered.triangles)
        assert covered.stats["nodes_visited"] <= walked.stats["nodes_visited"]
        assert covered.stats["vfc.nodes_covered"] >= 0
        assert "vfc.nodes_covered" not in walked.stats
    # Facing the other way, straddling nodes hold nothing the planes reject (the boxes are
    # shrunk to their content, culling/tree.py: the first view has none such).
    back = Camera((5.0, 1.7, 5.0), yaw=180.0, pitch=0.0, aspect=0.75)
    assert Culler(w1_octree, "vfc").cull(back).stats["vfc.nodes_covered"] > 0
    for stages in ("vfc,vfc_thesis", "vfc,occlusion_thesis"):
        assert not next(s for s in Culler(w1_octree, stages).stages if s.name == "vfc").covering
    unfused = Culler(w1_octree, "vfc,occlusion", occlusion={"fuse": False})
    assert not unfused.stages[0].covering
    with pytest.raises(ValueError, match="cover"):
        Culler(w1_octree, "vfc", vfc={"cover": 1})
