"""T-junction repair (world/tjunctions.py): planted junctions are split with the existing floats,
area and winding are kept, no edge passes a vertex afterwards, and the real rasteriser no longer
shows what lies behind a crease it showed before."""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.device.profile import get_profile
from vismobile.partition.pvs_cracks import unshared_edges
from vismobile.render import item_buffer
from vismobile.world.tjunctions import ear_clip, find_tjunctions, repair_tjunctions
from vismobile.world.world import World

MODES = ("float64", "float32", "fixed16.16")
TRAJECTORY = Path(__file__).resolve().parents[1] / "trajectories" / "indoor.csv"


def planted(rng, base_count, splits):
    """A soup of random triangles; against each, `splits` triangles on the far side of one of
    its edges whose corners lie on that edge at random parameters (T-junctions), in the same
    plane so the two surfaces meet in a crease."""
    vertices, triangles, junctions = [], [], 0
    for _ in range(base_count):
        a, b, c = rng.uniform(-10, 10, (3, 3))
        if np.linalg.norm(np.cross(b - a, c - a)) < 1.0:
            continue
        base = len(vertices)
        vertices += [a, b, c]
        triangles.append([base, base + 1, base + 2])
        ts = np.sort(rng.choice(np.arange(1, 16), splits, replace=False)) / 16.0
        apex = a + b - c  # beyond edge ab, in the triangle's plane
        on_edge = [a] + [a + (b - a) * s for s in ts] + [b]
        for p0, p1 in zip(on_edge[:-1], on_edge[1:]):
            k = len(vertices)
            vertices += [p0, p1, apex]
            triangles.append([k + 1, k, k + 2])  # the neighbour runs the edge the other way
        junctions += splits
    return World(np.array(vertices), np.array(triangles)), junctions


def vertex_on_edge_interior(world, tol):
    """(edge, vertex) pairs where a vertex lies strictly inside some triangle's edge."""
    points = np.unique(world.vertices, axis=0)
    index = {tuple(p): i for i, p in enumerate(points)}
    ids = np.array([index[tuple(v)] for v in world.vertices])[world.triangles]
    edges = np.concatenate([ids[:, [0, 1]], ids[:, [1, 2]], ids[:, [2, 0]]])
    return find_tjunctions(points, np.unique(np.sort(edges, axis=1), axis=0), tol)[0]


def junctions_per_triangle(world, tol):
    """(T,) int: vertices lying strictly inside each triangle's edges (brute force)."""
    points = np.unique(world.vertices, axis=0)
    out = np.zeros(world.triangle_count, dtype=np.int64)
    for t, corners in enumerate(world.corners):
        for a, b in ((corners[0], corners[1]), (corners[1], corners[2]), (corners[2], corners[0])):
            d = b - a
            s = (points - a) @ d / (d @ d)
            off = np.linalg.norm(points - a - s[:, None] * d, axis=1)
            length = np.linalg.norm(d)
            out[t] += int(((s * length > tol) & ((1 - s) * length > tol) & (off <= tol)).sum())
    return out


def cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@settings(max_examples=60)
@given(st.integers(0, 2**32 - 1), st.lists(st.integers(0, 6), min_size=3, max_size=3))
def test_ear_clip_covers_a_ring_with_the_fewest_triangles(seed, counts):
    """Any junctions on any edges: len - 2 triangles, none degenerate, all wound as the
    parent, their areas summing to its area (so they tile it: a convex polygon)."""
    rng = np.random.default_rng(seed)
    corners = rng.uniform(-5, 5, (3, 2))
    if abs(cross2(corners[1] - corners[0], corners[2] - corners[0])) < 0.5:
        return
    points, lines = [], []
    for k in range(3):
        a, b = corners[k], corners[(k + 1) % 3]
        points.append(a)
        lines.append({(k + 2) % 3, k})
        for s in np.sort(rng.choice(np.arange(1, 64), counts[k], replace=False)) / 64.0:
            points.append(a + s * (b - a))
            lines.append({k})
    points = np.array(points)
    triangles = np.array(ear_clip(lines))
    assert len(triangles) == len(points) - 2
    p = points[triangles]
    area = cross2(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) / 2
    parent = cross2(corners[1] - corners[0], corners[2] - corners[0]) / 2
    assert (np.sign(area) == np.sign(parent)).all()
    assert np.abs(area).min() > 1e-9
    np.testing.assert_allclose(area.sum(), parent, rtol=1e-9)


@settings(max_examples=25)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.integers(1, 4))
def test_planted_junctions_are_split_with_the_same_floats(seed, count, splits):
    world, planted_count = planted(np.random.default_rng(seed), count, splits)
    if world.triangle_count == 0:
        return
    tol = 1e-9 * float(np.linalg.norm(np.ptp(world.extent, axis=0)))
    before = vertex_on_edge_interior(world, tol)
    assert len(before) >= planted_count  # the planted ones (random bases may add more)
    fixed, repair = repair_tjunctions(world)
    assert repair.junctions == len(before)
    # area per parent kept, winding kept, object ids follow the parent
    area = np.bincount(repair.parent, fixed.areas, world.triangle_count)
    np.testing.assert_allclose(area, world.areas, rtol=1e-9, atol=1e-12)
    assert ((fixed.normals * world.normals[repair.parent]).sum(axis=1) > 1 - 1e-9).all()
    assert (fixed.object_ids == world.object_ids[repair.parent]).all()
    assert (np.diff(repair.parent) >= 0).all()
    # barycentric corners reproduce the new corners (within the junctions' 0 offset)
    corners = np.einsum("tij,tjk->tik", repair.bary, world.corners[repair.parent])
    np.testing.assert_allclose(corners, fixed.corners, atol=1e-9)
    # no vertex inside an edge any more, and the planted creases are shared corner to corner:
    # only the outer borders stay unshared (2 per base, 2 per fan of neighbours)
    assert not len(vertex_on_edge_interior(fixed, tol))
    again, second = repair_tjunctions(fixed)  # idempotent: a repaired OBJ reloaded
    assert second.junctions == 0 and again.digest() == fixed.digest()
    bases = world.triangle_count // (splits + 2)
    assert len(unshared_edges(fixed)) == 4 * bases
    assert len(unshared_edges(world)) == (6 + splits) * bases  # + the base's ab, the strips'
    # every vertex of the repaired world is one of the input's floats (no new vertex), and each
    # triangle became one piece more than it has junctions on its edges (the fewest)
    known = {tuple(v) for v in world.vertices}
    assert all(tuple(v) in known for v in fixed.vertices[np.unique(fixed.triangles)])
    pieces = np.bincount(repair.parent, minlength=world.triangle_count)
    np.testing.assert_array_equal(pieces, 1 + junctions_per_triangle(world, tol))


def test_a_world_without_junctions_is_unchanged(literal):
    world = literal.world([literal.rect(1, 0.0, (0, 4), (0, 4), 1),
                           literal.rect(0, 0.0, (0, 3), (0, 4), 1)])
    fixed, repair = repair_tjunctions(world)
    assert repair.junctions == repair.split == 0
    assert (fixed.triangles == world.triangles).all() and fixed.digest() == world.digest()


def test_textures_are_interpolated(literal):
    world = literal.world([literal.rect(1, 0.0, (0, 2), (0, 2), 1),
                           literal.rect(1, 0.0, (0, 1), (2, 3), 1),
                           literal.rect(1, 0.0, (1, 2), (2, 3), 1)])
    from vismobile.world.textures import Textures

    # uv = (x, z) / 4 at every corner
    world.textures = Textures((world.corners[:, :, [0, 2]] / 4).astype(np.float32),
                              np.zeros(3, np.int32))
    fixed, repair = repair_tjunctions(world)
    assert repair.split == 1  # the big quad's triangle along z = 2 takes x = 1
    np.testing.assert_allclose(fixed.textures.uv, fixed.corners[:, :, [0, 2]] / 4, atol=1e-6)


@pytest.mark.parametrize("mode", MODES)
def test_the_rasteriser_sees_nothing_through_a_repaired_crease(literal, mode):
    profile = get_profile(get_profile("ipaq-hx2490b"), mode) if mode != "float64" \
        else get_profile("ipaq-hx2490b")
    world = literal.crease_world()
    fixed, repair = repair_tjunctions(world)
    assert repair.junctions >= 22 and len(unshared_edges(fixed)) < len(unshared_edges(world))
    far = np.arange(world.triangle_count - 2, world.triangle_count)
    far_fixed = np.flatnonzero(np.isin(repair.parent, far))
    before = after = 0
    for cam in literal.crease_cameras(profile, 100):
        before += np.isin(far, item_buffer(world, None, cam, profile, cull_back=False)).any()
        after += np.isin(far_fixed, item_buffer(fixed, None, cam, profile,
                                                cull_back=False)).any()
    assert before >= 1  # the crack was open before (else this test checks nothing)
    assert after == 0, f"{mode}: {after} of 100 cameras still see the slab through the crease"


def test_a_partition_keeps_its_repair_and_refuses_the_other_world(tmp_path, literal, capsys):
    """A .vmp baked on a repaired world carries it (header world.repair); loading it with the
    unrepaired world, or playing an unrepaired one with --repair, is refused in one line."""
    from vismobile.app.cli import main
    from vismobile.errors import PartitionError
    from vismobile.files.loader import load_world
    from vismobile.partition import load_partition, partition, save_partition

    path = tmp_path / "crease.obj"
    literal.crease_world().to_obj(path)
    plain, fixed = load_world(path), load_world(path, repair="tjunctions")
    assert plain.repair is None and fixed.repair == "tjunctions"
    assert fixed.triangle_count > plain.triangle_count
    save_partition(partition(fixed, "grid"), tmp_path / "fixed.vmp")
    loaded = load_partition(tmp_path / "fixed.vmp", world=fixed)
    assert loaded.world.repair == "tjunctions" and loaded.world.digest() == fixed.digest()
    with pytest.raises(PartitionError, match="--repair tjunctions, given with --repair none"):
        load_partition(tmp_path / "fixed.vmp", world=plain)
    assert main(["partition", str(path), "--structure", "grid", "-o",
                 str(tmp_path / "plain.vmp")]) == 0
    capsys.readouterr()
    assert main(["play", str(tmp_path / "plain.vmp"), "--repair", "tjunctions", "--trajectory",
                 str(TRAJECTORY), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "built without --repair tjunctions" in err[0], err
    assert not (tmp_path / "out").exists()
    assert main(["info", str(path), "--repair", "tjunctions"]) == 0
    assert f"-> {fixed.triangle_count:,} triangles" in capsys.readouterr().out


def test_partition_repairs_for_a_conservative_pvs_unless_told_not_to(tmp_path, literal, capsys):
    """partition's --repair auto (the default) repairs a world with T-junctions when it bakes
    a conservative PVS, and says so; --repair none, or a structure without a PVS, keeps the
    world as given; a bad value is refused (exit 2) and writes nothing."""
    from vismobile.app.cli import main
    from vismobile.partition import load_partition

    path = tmp_path / "crease.obj"
    world = literal.crease_world()
    world.to_obj(path)
    runs = {"auto": ["--structure", "grid:pvs=conservative"],
            "none": ["--structure", "grid:pvs=conservative", "--repair", "none"],
            "nopvs": ["--structure", "grid"]}
    for name, argv in runs.items():
        assert main(["partition", str(path), *argv, "-o", str(tmp_path / f"{name}.vmp")]) == 0
        said = "repair      tjunctions (auto" in capsys.readouterr().out
        loaded = load_partition(tmp_path / f"{name}.vmp")
        assert said == (name == "auto") and (loaded.world.repair == "tjunctions") == said
        assert (loaded.world.triangle_count > world.triangle_count) == said
    with pytest.raises(SystemExit) as refused:  # argparse's choices
        main(["partition", str(path), "--structure", "grid:pvs=conservative", "--repair",
              "always", "-o", str(tmp_path / "bad.vmp")])
    assert refused.value.code == 2
    assert "argument --repair: invalid choice: 'always'" in capsys.readouterr().err
    assert not (tmp_path / "bad.vmp").exists()
