"""The viewer on a terrain: T cycles tau, M the method, stages toggle, frames are the scene's."""
import numpy as np
import pytest

from vismobile.app.terrain_scene import TerrainScene
from vismobile.terrain import sources, store
from vismobile.terrain.placement import place_objects
from vismobile.viewer.terrain_session import TERRAIN_TAUS, TerrainSession


@pytest.fixture(scope="module")
def terrain(tmp_path_factory):
    hm = sources.diamond_square(129, seed=3, roughness=0.55, relief=0.15)
    path = tmp_path_factory.mktemp("view") / "t.vmt"
    store.save(path, hm, place_objects(hm, 20, seed=1, height=4.0))
    return path


def test_keys_switch_tau_method_and_stages_and_frames_match_the_scene(terrain, tmp_path):
    session = TerrainSession.open_terrain(terrain, "tiles", 1.0, ("vfc", "horizon"),
                                          "octree:3", record_path=tmp_path / "r.csv")
    first = session.render()
    assert first.info["method"] == "tiles" and first.info["ground_triangles"] > 0
    session.key_down("UP")
    for _ in range(3):
        session.update(0.1)
    session.key_up("UP")
    session.key_down("T")
    assert session.terrain.tau == TERRAIN_TAUS[TERRAIN_TAUS.index(1.0) + 1]
    coarser = session.render()
    session.key_down("M")
    assert session.terrain.method == "roettger"
    session.key_down("M")
    assert session.terrain.method == "roam"
    roam = session.render()
    assert roam.info["method"] == "roam" and roam.info["error_px"] <= session.terrain.tau + 1e-9
    session.key_down("H")  # horizon off: every object in the frustum is sent
    assert "horizon" not in session.stages
    without = session.render()
    assert without.info["object_triangles"] >= roam.info["object_triangles"]
    # The frame is the scene's own for the same camera, method and tau.
    scene = TerrainScene(terrain, "roam", session.terrain.tau, session.stages, "octree:3")
    scene.frame(without.camera)
    again = scene.frame(without.camera)  # ROAM converges from its roots in a frame or two
    session.render()
    assert np.array_equal(scene.read_rgb(), session.render().image)
    assert again.ground_triangles == session.last_frame.info["ground_triangles"]
    assert coarser.info["tau"] == 2.0


@pytest.mark.parametrize("suffix, method", [(".vmtiles", "tiles"), (".vmrpages", "roettger")])
def test_a_paged_terrain_flies_through_with_its_own_method(tmp_path, suffix, method):
    """view t.vmtiles / t.vmrpages: the paged terrain's own method at tau (the god view's ground
    from its coarse samples); M says the method stays; T still cycles tau."""
    from vismobile.app.cli import main

    store.save(tmp_path / "t.vmt", sources.diamond_square(129, seed=3))
    path = tmp_path / f"t{suffix}"
    assert main(["terrain", "tile", str(tmp_path / "t.vmt"), "-o", str(path)]) == 0
    session = TerrainSession.open_terrain(path, None, 1.0, (), "none",
                                          record_path=tmp_path / "r.csv")
    first = session.render()
    assert first.info["method"] == method and first.info["ground_triangles"] > 0
    assert session.world.triangle_count > 0  # the stand-in ground
    session.key_down("M")
    assert session.terrain.method == method and "method only" in session.message
    session.key_down("T")
    assert session.render().info["tau"] == 2.0
