"""The viewer's logic without a window: scripted keys, recording, playback, toggles, frames."""
import numpy as np
import pytest

from vismobile.partition import partition
from vismobile.app.playback import Scene
from vismobile.render import render_rgb
from vismobile.world.trajectory import Trajectory
from vismobile.viewer import Session
from vismobile.viewer.layout import PANEL


@pytest.fixture(scope="module")
def scene(thesis_world):
    world = thesis_world("w1")
    return Scene(world, partition(world, "octree", depth=3), Session._label("octree:3"))


@pytest.fixture
def session(scene, tmp_path):
    return Session(scene, (), "ipaq-hx2490b", "trajectories/indoor.csv",
                   record_path=tmp_path / "recorded.csv",
                   structures=("none", "octree:3", "portal:1"))


def hold(session, key, updates, dt=0.1):
    session.key_down(key)
    for _ in range(updates):
        session.update(dt)
    session.key_up(key)


def test_scripted_keys_record_a_trajectory_that_replays_to_the_same_cameras(session, tmp_path):
    session.key_down("R")
    hold(session, "UP", 6)
    hold(session, "LEFT", 4)
    hold(session, "PAGEUP", 3)
    session.key_down("R")
    assert not session.recorder.on and len(session.recorder) == 13
    recorded = session.recorder.poses
    assert np.linalg.norm(recorded[5, :3] - recorded[0, :3]) > 0 and recorded[9, 3] != recorded[5, 3]
    assert recorded[12, 1] > recorded[9, 1]
    session.key_down("V")
    saved = tmp_path / "recorded.csv"
    loaded = Trajectory.load(saved)
    assert np.allclose(loaded.poses, recorded, atol=1e-3)  # the CSV keeps 4 and 3 decimals

    session.key_down("L")  # loads the file just saved and plays it
    assert session.mode == "play"
    cameras = [session.camera()]
    for _ in range(len(loaded) - 1):
        session.update(0.1)
        cameras.append(session.camera())
    assert cameras == list(loaded.cameras(session.profile.aspect))


def test_pause_and_step(session):
    session.key_down("L")  # the --trajectory file
    for _ in range(5):
        session.update(0.1)
    session.key_down("SPACE")
    assert session.mode == "pause"
    session.update(0.1)
    assert session.player.frame == 5
    session.key_down("PERIOD")
    session.key_down("PERIOD")
    session.key_down("COMMA")
    assert session.player.frame == 6
    assert session.camera() == Trajectory.load("trajectories/indoor.csv").camera(
        6, session.profile.aspect)
    session.key_down("P")  # back to flying from where playback stopped
    assert session.mode == "fly"
    session.key_down("UP")
    session.update(0.1)
    assert not np.array_equal(session.pose, session.player.pose())


def test_toggles_change_the_triangles_sent(session):
    total = session.world.triangle_count
    none = session.render()
    assert len(none.triangles) == total and none.info["sent"] == total
    session.key_down("_1")  # vfc
    vfc = session.render()
    assert session.stages == ("vfc",)
    assert 0 < len(vfc.triangles) < total
    session.key_down("_6")  # occlusion
    both = session.render()
    assert set(both.triangles) <= set(vfc.triangles) and len(both.triangles) < len(vfc.triangles)
    session.key_down("_1")
    session.key_down("_6")
    assert len(session.render().triangles) == total
    session.key_down("_2")  # bfc: everything sent, the driver culls back faces
    frame = session.render()
    assert len(frame.triangles) == total and session.culler.cull_back


def test_structures_cycle_and_keep_the_stages_they_can_run(session):
    session.key_down("_1")
    session.key_down("TAB")  # portal:1
    assert session.structure == Session._label("portal:1") and session.stages == ("vfc",)
    session.key_down("_7")
    assert session.stages == ("vfc", "portals")
    session.key_down("TAB")  # none: no partition, so no vfc or portals
    assert session.structure == "none" and session.stages == ()
    assert len(session.render().triangles) == session.world.triangle_count
    session.key_down("_1")  # refused without a partition, with a message
    assert session.stages == () and "need a partition" in session.message


def test_frame_is_the_headless_renderers_image_of_the_same_camera(session):
    session.key_down("_1")
    hold(session, "UP", 3)
    frame = session.render()
    expected = render_rgb(session.world, frame.triangles, frame.camera, session.profile)
    assert frame.image.shape == (320, 240, 3)
    assert np.array_equal(frame.image, expected)


def test_overlays_draw_over_the_frame(session):
    session.key_down("_1")
    session.key_down("_6")
    plain = session.render().image
    session.key_down("C")
    culled = session.render().image
    session.key_down("C")
    session.key_down("B")
    boxes = session.render().image
    assert not np.array_equal(plain, culled) and not np.array_equal(plain, boxes)
    # x-ray red: culled geometry behind the walls tints the image toward red
    assert culled[..., 0].astype(int).sum() > plain[..., 0].astype(int).sum()
    # ... by one layer however many culled triangles lie behind a pixel: each pixel is the
    # plain one or 30% of the way to red, so the view stays readable.
    once = 0.7 * plain + 0.3 * np.array([255, 40, 40])
    changed = (culled != plain).any(axis=-1)
    assert changed.any() and np.abs(culled[changed] - once[changed]).max() <= 1.0


def test_hud_reports_the_frame(session):
    session.key_down("_1")
    frame = session.render()
    text = "\n".join(frame.hud)
    assert f"sent {len(frame.triangles):,} / {session.world.triangle_count:,}" in text
    assert f"VFC  /  {Session._label('octree:3')}" in text
    assert "fps (iPaq hx2490b model)" in text and "/ 64 MB heap" in text
    assert frame.info["nodes_visited"] == frame.stats["nodes_visited"] > 0
    session.key_down("L")
    for _ in range(55):
        session.update(0.1)
    assert "waypoint A in 1 frames" in "\n".join(session.render().hud)


def test_god_view_cycles_top_side_off(session):
    assert session.render().god.shape == (PANEL, PANEL, 3)
    session.key_down("G")
    assert session.god_view == "side" and session.render().god is not None
    session.key_down("G")
    assert session.render().god is None


def test_desktop_frames_follow_the_window(scene):
    session = Session(scene, ("vfc",), "desktop")
    session.set_view_size(320, 200)
    frame = session.render()
    assert frame.image.shape == (200, 320, 3) and frame.camera.aspect == 1.6
    assert frame.info["device_fps"] is None


def test_saving_nothing_or_loading_nothing_is_a_message_not_an_error(scene, tmp_path):
    session = Session(scene, (), "ipaq-hx2490b", record_path=tmp_path / "r.csv")
    session.key_down("V")
    assert "nothing recorded" in session.message and not (tmp_path / "r.csv").exists()
    session.key_down("L")
    assert "no trajectory" in session.message and session.mode == "fly"
    bad = tmp_path / "bad.csv"
    bad.write_text("frame,x\n")
    assert not session.load_trajectory(bad) and str(bad) in session.message


def test_structures_over_the_heap_are_skipped_and_worlds_refused(scene, tmp_path):
    from vismobile.errors import ProfileError
    from vismobile.device.profile import get_profile

    ipaq = get_profile("ipaq-hx2490b")
    fits = ipaq.estimate_memory(scene.world, scene.partition)["total"]
    small = ipaq.with_(heap_bytes=fits)            # octree:3 fits exactly; octree:6 does not
    session = Session(scene, ("vfc",), small, record_path=tmp_path / "r.csv",
                      structures=("octree:3", "octree:6", "none"))
    session.key_down("TAB")
    assert session.structure == "none" and "octree 6" in session.message.replace(":", " ")
    assert "over the" in session.message
    assert not session.set_structure("octree:6") and session.structure == "none"
    with pytest.raises(ProfileError, match="heap"):
        Session(scene, (), ipaq.with_(heap_bytes=fits - 1), record_path=tmp_path / "r.csv")


def test_tab_builds_on_a_thread_while_frames_go_on(scene, tmp_path):
    import time

    session = Session(scene, ("vfc",), "ipaq-hx2490b", record_path=tmp_path / "r.csv",
                      structures=("octree:3", "octree:5"))
    session.background_builds = True
    session.key_down("TAB")
    assert session.structure == Session._label("octree:3") and "building" in session.message
    session.key_down("TAB")                                   # one build at a time
    assert "still building" in session.message
    frames, start = 0, time.perf_counter()
    while session.structure != Session._label("octree:5"):
        assert time.perf_counter() - start < 120, "the build never finished"
        session.update(0.05)
        session.render()                                      # the view goes on meanwhile
        frames += 1
    assert frames >= 1 and session.stages == ("vfc",)
    assert session.render().stats["nodes_visited"] > 0


def test_a_tap_of_up_moves_one_step_and_a_hold_moves_on(session):
    from vismobile.viewer.session import TAP_SECONDS

    assert session.mode == "fly"
    start = session.pose.copy()
    session.key_down("UP")
    session.key_up("UP")  # no update between: a tap
    tapped = np.linalg.norm(session.pose[[0, 2]] - start[[0, 2]])
    assert np.isclose(tapped, session.speeds.move * TAP_SECONDS)
    moved = session.pose.copy()
    session.update(0.1)  # released: no further move
    assert np.allclose(session.pose, moved)
    hold(session, "UP", 3)  # a hold moves with each update, and not again on release
    held = np.linalg.norm(session.pose[[0, 2]] - moved[[0, 2]])
    assert np.isclose(held, 3 * 0.1 * session.speeds.move)


def test_screenshot_key_saves_the_view(session, tmp_path):
    session.key_down("K")  # before any frame: a message, no file
    assert "no frame" in session.message
    frame = session.render()
    session.key_down("K")
    session.key_down("F12")
    shots = sorted(tmp_path.glob("vismobile-*.png"))
    assert [p.name for p in shots] == ["vismobile-001.png", "vismobile-002.png"]
    from PIL import Image

    assert np.array_equal(np.asarray(Image.open(shots[0]).convert("RGB")), frame.image)
    assert "saved" in session.message


def test_a_mesh_without_a_trajectory_starts_inside_at_eye_height(tmp_path):
    import trimesh

    from vismobile.viewer.session import start_pose
    from vismobile.world.world import World

    room = World.from_trimesh(trimesh.creation.box(extents=(10.0, 4.0, 10.0)), name="room")
    pose = start_pose(room)
    low, high = room.extent
    assert (low[[0, 2]] < pose[[0, 2]]).all() and (pose[[0, 2]] < high[[0, 2]]).all()
    assert low[1] < pose[1] < high[1]
    room.to_obj(tmp_path / "room.obj")
    opened = Session.open(tmp_path / "room.obj", "none", (), "desktop",
                          record_path=tmp_path / "r.csv")
    assert np.allclose(opened.pose, pose)


def test_an_animated_scene_moves_on_screen_and_the_hud_counts_it(thesis_world):
    from vismobile.app.playback import load_scene

    scene = load_scene("w7", "octree:3")
    session = Session(scene, ("vfc",), "ipaq-hx2490b", "trajectories/hybrid.csv",
                      structures=("octree:3",))
    session.pose = np.array([75.0, 1.7, 150.0, 0.0, 0.0])  # the street, cars passing
    images = []
    for dt in (0.0, 1.5):
        session.update(dt)
        frame = session.render()
        posed = scene.animated.posed(session.scene_time())
        assert np.array_equal(frame.image, render_rgb(posed, frame.triangles, frame.camera,
                                                      session.profile))
        assert any(line.startswith("moving 67 objects") for line in frame.hud)
        images.append(frame.image)
    assert not np.array_equal(images[0], images[1])  # the cars moved
