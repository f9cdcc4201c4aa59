"""Winding: consistency across shared edges, closed rooms seen from inside, --fix-winding, and
tune refusing to call back-face culling exact on a room whose walls face out (trimesh's box)."""
import json
import numpy as np
import pytest
import trimesh

from vismobile.device.profile import get_profile
from vismobile.world.trajectory import Trajectory
from vismobile.world.winding import check_winding, fixed_world
from vismobile.world.world import World

CENTRE = np.array([0.0, 1.5, 0.0])


def room_mesh():
    """A 10 x 3 x 8 trimesh box: normals outward, as trimesh makes it (wrong for a room)."""
    box = trimesh.creation.box(extents=(10, 3, 8))
    box.apply_translation(CENTRE)
    return box


def facing_centre(world) -> np.ndarray:
    """(T,) bool: the triangle's normal points toward the room's centre."""
    return np.einsum("ij,ij->i", world.normals, CENTRE - world.centroids) > 0


def test_trimesh_room_faces_out_and_the_fix_turns_every_wall_inward():
    world = World.from_trimesh(room_mesh(), "room")
    report = check_winding(world)
    assert report.consistent and report.open_edges == 0 and report.nonmanifold_edges == 0
    assert report.rooms == 1 and report.room_faces == report.room_faces_outward == 12
    assert not facing_centre(world).any()
    fixed, _ = fixed_world(world, report)
    assert facing_centre(fixed).all()
    again = check_winding(fixed)
    assert again.room_faces_outward == 0 and again.to_fix == 0
    mesh = trimesh.Trimesh(fixed.vertices, fixed.triangles, process=False)
    assert mesh.is_winding_consistent and mesh.volume < 0  # inward: negative signed volume


def test_scrambled_winding_is_reported_and_made_consistent():
    box = room_mesh()
    faces = box.faces.copy()
    faces[[1, 4, 7]] = faces[[1, 4, 7], ::-1]
    assert not trimesh.Trimesh(box.vertices, faces, process=False).is_winding_consistent
    report = check_winding(World(box.vertices, faces))
    assert not report.consistent and report.inconsistent_faces == 3
    fixed, _ = fixed_world(World(box.vertices, faces), report)
    assert trimesh.Trimesh(fixed.vertices, fixed.triangles, process=False).is_winding_consistent
    assert facing_centre(fixed).all()


def test_a_solid_in_the_room_faces_out_and_the_room_in():
    solid = trimesh.creation.box(extents=(1, 1, 1))
    solid.apply_translation((2, 0.5, 1))
    room = room_mesh()
    world = World.concatenate([World(room.vertices, room.faces[:, ::-1]),  # room correct
                               World(solid.vertices, solid.faces[:, ::-1])])  # solid inside out
    report = check_winding(world)
    assert report.rooms == 1 and report.solids == 1
    assert report.room_faces_outward == 0 and report.solid_faces_inward == 12
    fixed, _ = fixed_world(world, report)
    assert np.array_equal(fixed.triangles[:12], world.triangles[:12])  # the room untouched
    part = trimesh.Trimesh(fixed.vertices, fixed.triangles[12:], process=False)
    assert part.volume > 0


def test_eyes_outside_a_lone_closed_mesh_make_it_a_solid():
    world = World.from_trimesh(room_mesh(), "crate")
    outside = [[20.0, 1.5, 0.0], [0.0, 1.5, 30.0]]
    report = check_winding(world, eyes=outside)
    assert report.rooms == 0 and report.solids == 1 and report.to_fix == 0
    assert check_winding(world, eyes=[[0.0, 1.5, 0.0]]).room_faces_outward == 12
    fixed, _ = fixed_world(world, eyes=outside)
    assert fixed is world


def test_open_and_non_manifold_edges_are_counted():
    box = room_mesh()
    open_box = World(box.vertices, box.faces[2:])  # one side missing: a four-edge hole
    report = check_winding(open_box)
    assert report.open_edges == 4 and report.rooms == 0 and report.solids == 0
    assert not trimesh.Trimesh(box.vertices, box.faces[2:], process=False).is_watertight
    fin = World([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]],
                [[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # three triangles on edge 0-1
    assert check_winding(fin).nonmanifold_edges == 1


def test_correct_worlds_are_left_alone():
    from tests.study.conftest import tiny_world

    assert check_winding(tiny_world()).to_fix == 0


def test_tune_ignores_one_pixel_silhouette_ties():
    """The tiny world's one back face seen (a box's bottom, 1 pixel at its silhouette) is
    1.5% of its visible triangles but not of their pixels: no warning."""
    from tests.study.conftest import tiny_world
    from vismobile.study.tune import tune

    frames = 8
    poses = np.column_stack([np.linspace(-8, 8, frames), np.full(frames, 1.6),
                             np.full(frames, 3.0), np.linspace(-60, 90, frames),
                             np.linspace(-10, 10, frames)])
    result = tune(tiny_world(), Trajectory(poses, {"A": 2, "B": 5}),
                  get_profile("ipaq-hx2490b"), probe=4, structures="octree:1")
    behind, visible, behind_pixels, pixels = result.behind
    assert behind > 0.01 * visible and behind_pixels < 0.01 * pixels
    assert result.warning is None


def room_walk(frames=8) -> Trajectory:
    """A walk along the room's long axis, turning to see every wall."""
    x = np.linspace(-3.5, 3.5, frames)
    poses = np.column_stack([x, np.full(frames, 1.6), np.zeros(frames),
                             np.linspace(0, 315, frames), np.zeros(frames)])
    return Trajectory(poses)


def test_tune_never_calls_backface_culling_exact_on_outward_walls():
    from vismobile.culling import BACKFACE_STAGES
    from vismobile.study.matrix import cull_stages
    from vismobile.study.tune import tune

    world = World.from_trimesh(room_mesh(), "room")
    result = tune(world, room_walk(), get_profile("ipaq-hx2490b"), probe=4,
                  structures="octree:1")
    behind, visible, behind_pixels, pixels = result.behind
    assert visible > 0 and behind == visible and behind_pixels == pixels  # every wall
    assert result.warning and "no configuration with bfc" in result.warning
    assert "WARNING: back-face culling removes" in result.report()
    assert result.to_dict()["backface_exact"] is False
    for cand in result.candidates:
        if any(s in BACKFACE_STAGES for s in cull_stages(cand.cull)):
            assert cand.false_negatives > 0
    assert not any(s in BACKFACE_STAGES for s in cull_stages(result.choice.cull))
    lossy = {cull for _, cull, why in result.pruned if why.startswith("missed")}
    assert any("bfc" in cull_stages(c) for c in lossy)
    fixed = tune(fixed_world(world)[0], room_walk(), get_profile("ipaq-hx2490b"), probe=4,
                 structures="octree:1")
    assert fixed.warning is None and fixed.behind[0] == 0
    assert fixed.to_dict()["backface_exact"] is True


def test_cli_info_reports_and_fixes_the_winding(tmp_path, vismobile_cli):
    room_mesh().export(tmp_path / "room.stl")
    shown = vismobile_cli("info", "room.stl", cwd=tmp_path)
    assert shown.returncode == 0, shown.stderr
    assert "12 of 12 triangles face away from the interior" in shown.stdout
    assert "--fix-winding reverses 12 triangles" in shown.stdout
    fixed = vismobile_cli("info", "room.stl", "--fix-winding", "-o", "fixed.obj", cwd=tmp_path)
    assert fixed.returncode == 0, fixed.stderr
    assert "0 of 12 triangles face away" in fixed.stdout
    assert facing_centre(World.from_file(tmp_path / "fixed.obj")).all()
    built = vismobile_cli("partition", "room.stl", "--fix-winding", "-s", "octree:1", "-o", "r.vmp",
                      cwd=tmp_path)
    assert built.returncode == 0 and "reversed 12 of 12 triangles" in built.stderr
    from vismobile.partition import load_partition

    assert facing_centre(load_partition(tmp_path / "r.vmp").world).all()
    room_walk().save(tmp_path / "walk.csv")
    refused = vismobile_cli("play", "r.vmp", "--fix-winding", "--trajectory", "walk.csv", "-o", "p",
                        cwd=tmp_path)
    assert refused.returncode == 2
    assert refused.stderr.count("\n") == 1 and "--fix-winding applies to a mesh" in refused.stderr
    played = vismobile_cli("play", "room.stl", "--fix-winding", "--trajectory", "walk.csv",
                           "--structure", "octree:1", "--cull", "vfc,bfc", "--frames", "sample:2",
                           "-o", "p", "--quiet", cwd=tmp_path)
    assert played.returncode == 0 and "reversed 12 of 12 triangles" in played.stderr, played.stderr
    tuned = vismobile_cli("tune", "room.stl", "--trajectory", "walk.csv", "--probe", "3",
                      "--structures", "octree:1", "--quiet", cwd=tmp_path)
    assert tuned.returncode == 0, tuned.stderr
    assert "WARNING: back-face culling removes" in tuned.stdout
    choice = next(line for line in tuned.stdout.splitlines() if line.startswith("choice:"))
    assert not any(stage in choice.split("--cull")[1] for stage in ("bfc", "cone"))
    fixed_tune = vismobile_cli("tune", "room.stl", "--fix-winding", "--trajectory", "walk.csv",
                           "--probe", "3", "--structures", "octree:1", "--quiet", cwd=tmp_path)
    assert fixed_tune.returncode == 0 and "WARNING" not in fixed_tune.stdout
    assert "reversed 12 of 12 triangles" in fixed_tune.stderr
    missing = vismobile_cli("info", "nothing.stl", "--fix-winding", cwd=tmp_path)
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1
    assert "nothing.stl" in missing.stderr and "Traceback" not in missing.stderr


def test_cli_compare_sweeps_the_fixed_copy_of_a_mesh_world(tmp_path, vismobile_cli):
    """compare --fix-winding writes OUT/fixed/room.obj and sweeps it instead of room.stl."""
    room_mesh().export(tmp_path / "room.stl")
    room_walk().save(tmp_path / "walk.csv")

    def compare(out, *extra):
        done = vismobile_cli("compare", "--worlds", "room.stl", "--trajectory", "walk.csv",
                             "--structures", "octree:1", "--cull", "vfc+tbfc", "--profiles",
                             "ipaq-hx2490b", "--frames", "sample:2", "--agreement", "0", "--jobs",
                             "1", "--quiet", "-o", out, *extra, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        return done, json.loads((tmp_path / out / "runs.json").read_text())

    done, fixed = compare("fixed", "--fix-winding")
    assert "room.stl: reversed 12 of 12 triangles" in done.stdout
    assert facing_centre(World.from_file(tmp_path / "fixed" / "fixed" / "room.obj")).all()
    _, plain = compare("plain")
    assert fixed[0]["world"].endswith("room.obj") and plain[0]["world"].endswith("room.stl")
    # From inside, tbfc drops every wall of the outward-facing room and none of the fixed one.
    assert plain[0]["triangles_sent"] == 0 and fixed[0]["triangles_sent"] > 0
