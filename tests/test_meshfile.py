"""Mesh files other than OBJ and trimesh objects: formats, scene flattening, errors."""
import gzip

import numpy as np
import pytest
import trimesh

from vismobile.app.cli import main
from vismobile.errors import WorldError
from vismobile.world.world import World


def box_scene():
    """Two unit boxes: one moved by +5 on x, one mirrored (scale -1 on x) and moved by -5."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(), node_name="right", geom_name="box",
                       transform=trimesh.transformations.translation_matrix([5, 0, 0]))
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    mirror[0, 3] = -5
    scene.add_geometry(trimesh.creation.box(), node_name="left", geom_name="box2",
                       transform=mirror)
    return scene


def outward(world):
    """True when every triangle's normal points away from its object's centre."""
    centres = np.array([world.centroids[world.object_ids == k].mean(axis=0)
                        for k in range(len(world.object_names))])
    return bool((np.einsum("ij,ij->i", world.normals,
                           world.centroids - centres[world.object_ids]) > 0).all())


@pytest.mark.parametrize("suffix", ["ply", "stl", "off", "glb"])
def test_each_format_loads_a_box(tmp_path, suffix):
    path = tmp_path / f"box.{suffix}"
    trimesh.creation.box(extents=(1, 2, 3)).export(path)
    world = World.from_file(path)
    assert world.triangle_count == 12 and world.name == "box"
    assert world.areas.sum() == pytest.approx(2 * (2 + 3 + 6))


def test_gzipped_ply_loads(tmp_path):
    data = trimesh.creation.box().export(file_type="ply")
    (tmp_path / "box.ply.gz").write_bytes(gzip.compress(data))
    assert World.from_file(tmp_path / "box.ply.gz").triangle_count == 12


def test_scene_nodes_become_objects_moved_by_their_transforms(tmp_path):
    path = tmp_path / "scene.glb"
    box_scene().export(path)
    world = World.from_file(path)
    assert sorted(world.object_names) == ["left", "right"]
    for name, x in (("left", -5), ("right", 5)):
        centre = world.centroids[world.object_ids == world.object_names.index(name)].mean(axis=0)
        np.testing.assert_allclose(centre, [x, 0, 0], atol=1e-6)
    assert outward(world)  # the mirrored node's faces were reversed


def test_from_trimesh_takes_a_mesh_or_a_scene():
    mesh = World.from_trimesh(trimesh.creation.icosphere(), name="ball")
    assert mesh.name == "ball" and len(mesh.object_names) == 1 and outward(mesh)
    scene = World.from_trimesh(box_scene())
    assert scene.triangle_count == 24 and len(scene.object_names) == 2


def test_scene_without_triangles_is_a_world_error():
    scene = trimesh.Scene([trimesh.PointCloud(np.zeros((3, 3)))])
    with pytest.raises(WorldError, match="no triangles"):
        World.from_trimesh(scene, name="points")


def test_unknown_format_names_the_file(tmp_path):
    path = tmp_path / "scene.xyz"
    path.write_text("1 2 3\n")
    with pytest.raises(WorldError, match=r"scene\.xyz.*unsupported mesh format"):
        World.from_file(path)


def test_garbage_ply_names_the_file(tmp_path):
    path = tmp_path / "bad.ply"
    path.write_text("ply\nthis is not a header\n")
    with pytest.raises(WorldError, match="bad.ply"):
        World.from_file(path)


def test_info_accepts_a_thesis_world_and_a_mesh_file(tmp_path, capsys, w5):
    assert main(["info", "w5"]) == 0
    assert "triangles  2,548" in capsys.readouterr().out
    path = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=1).export(path)
    assert main(["info", str(path)]) == 0
    assert "triangles  80" in capsys.readouterr().out


def test_compare_needs_a_trajectory_for_a_world_file(tmp_path, capsys):
    path = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=1).export(path)
    assert main(["compare", "--worlds", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "--trajectory" in capsys.readouterr().err
