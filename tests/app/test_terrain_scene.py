"""A terrain world through the engine: each LOD method with its objects culled by the horizon
stage over the drawn (LOD) ground, checked against the item buffer of that same ground plus
every object (the real renderer)."""
import numpy as np
import pytest

from vismobile.app.terrain_scene import METHODS, TerrainScene
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain import sources, store
from vismobile.terrain.placement import place_objects
from vismobile.world.camera import Camera


@pytest.fixture(scope="module")
def terrain(tmp_path_factory):
    hm = sources.diamond_square(129, seed=7, roughness=0.6, relief=0.2)
    path = tmp_path_factory.mktemp("terrain") / "t.vmt"
    store.save(path, hm, place_objects(hm, 60, seed=3, height=4.0))
    return path


def low_cameras(hm, count, seed):
    """Eyes 1 cm to 5 m above the ground, any heading, pitch -30..20, near 1e-3..1."""
    rng = np.random.default_rng(seed)
    cams = []
    for _ in range(count):
        x, z = rng.uniform(0.1, 0.9, 2) * hm.extent
        up = 10 ** rng.uniform(-2, np.log10(5.0))
        y = float(hm.height_at(x, z)) + up
        cams.append(Camera((x, y, z), yaw=rng.uniform(0, 360), pitch=rng.uniform(-30, 20),
                           fov=60, aspect=240 / 320, near=10 ** rng.uniform(-3, 0),
                           far=2 * hm.extent))
    return cams


def device(profile):
    """desktop (float32, 640x480) or the iPaq's screen in fixed16.16 (the Culler's arithmetic
    is the profile's vertex format; the registered profiles are float32)."""
    from vismobile.device.profile import get_profile

    return get_profile("ipaq-hx2490b", "fixed16.16") if profile == "fixed" else profile


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("profile", ["desktop", "fixed"])
def test_horizon_never_hides_a_visible_object_triangle(terrain, method, profile):
    scene = TerrainScene(terrain, method, 1.0, ("vfc", "horizon"), "octree:3", device(profile))
    assert scene.culler.arithmetic == ("fixed16.16" if profile == "fixed" else "float32")
    renderer = TerrainRenderer(scene.heightmap, scene.profile)
    hidden_total = 0
    for camera in low_cameras(scene.heightmap, 12, seed=len(method) + len(profile)):
        f = scene.frame(camera)
        assert f.error_px <= 1.0 + 1e-9
        lost = scene.visible_dropped(camera, renderer)
        assert lost == 0, f"{method}: {lost} visible triangles dropped"
        hidden_total += int(f.nodes_hidden) + int(f.triangles_hidden)
    print(method, profile, hidden_total)
    assert hidden_total > 0  # the stage works on these low views, not only stays safe


def test_play_writes_triangles_and_error_per_frame(terrain, tmp_path):
    import csv
    import json

    from vismobile.app.cli import main

    out = tmp_path / "run"
    code = main(["play", str(terrain), "--lod", "1", "--terrain-method", "roam", "--limit", "6",
                 "--no-object-lod", "--measure-error", "--quiet", "-o", str(out)])
    assert code == 0
    rows = list(csv.DictReader(open(out / "frames.csv")))
    assert len(rows) == 6
    assert all(int(r["ground_triangles"]) > 0 for r in rows)
    assert all(0 < float(r["error_px"]) <= 1.0 for r in rows)
    # the measured error at the samples stays within the bound (and so within tau)
    assert all(0 < float(r["sample_error_px"]) <= float(r["error_px"]) + 1e-6 for r in rows)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method"] == "roam" and summary["tau"] == 1.0


def test_play_help_mentions_terrains(capsys):
    from vismobile.app.cli import main

    with pytest.raises(SystemExit):
        main(["play", "--help"])
    text = capsys.readouterr().out
    assert ".vmt" in text and "--terrain-method" in text


def test_bad_terrain_play_input_is_one_line_and_exit_2(terrain, tmp_path, capsys):
    from tests.conftest import refuse

    refuse(capsys, ["play", terrain, "--lod", "0", "-o", tmp_path / "a"], "--lod", "> 0")
    refuse(capsys, ["play", terrain, "--gif", "-o", tmp_path / "b"], "--gif")
    refuse(capsys, ["play", terrain, "--cull", "vfc+nope", "-o", tmp_path / "c"], "nope")
    broken = tmp_path / "broken.vmt"
    broken.write_bytes(terrain.read_bytes()[:200])
    refuse(capsys, ["play", broken, "-o", tmp_path / "d"], "broken.vmt")
    assert not any((tmp_path / n).exists() for n in "abcd")  # no partial output


def test_tune_picks_the_cheapest_method_and_tau_within_the_error(terrain, tmp_path, capsys):
    import json

    from vismobile.app.cli import main

    out = tmp_path / "tune.json"
    assert main(["tune", str(terrain), "--probe", "2", "--max-error-px", "2", "--quiet",
                 "--no-object-lod", "-o", str(out)]) == 0
    result = json.loads(out.read_text())
    rows = result["rows"]
    assert {(r["method"], r["tau"]) for r in rows} == \
        {(m, t) for m in METHODS for t in (0.5, 1.0, 2.0)}
    assert result["choice"] == min(rows, key=lambda r: r["cost_ms"])
    assert all(r["error_px_max"] <= r["tau"] + 1e-9 for r in rows)
    assert "choice: --terrain-method" in capsys.readouterr().out


def test_the_same_knob_draws_the_objects_at_their_level_of_detail(tmp_path):
    """object_lod: each kept object at its coarsest level within tau (lod/); a coarser tau
    sends fewer object triangles, and the chains come from the cache the second time."""
    hm = sources.diamond_square(65, seed=2, roughness=0.5, relief=0.1)
    path = tmp_path / "few.vmt"
    store.save(path, hm, place_objects(hm, 3, seed=5, height=6.0))
    camera = Camera((32.0, float(hm.bounds()[1, 1]) + 20, 90.0), yaw=0, pitch=-25, fov=60,
                    aspect=240 / 320, near=0.1, far=300)
    sent = {}
    for tau in (0.5, 8.0):
        scene = TerrainScene(path, "tiles", tau, (), "none", object_lod=True,
                             cache_dir=tmp_path / "cache")
        sent[tau] = scene.frame(camera).object_triangles
        plain = TerrainScene(path, "tiles", tau, (), "none")
        assert plain.frame(camera).object_triangles >= sent[tau]
    assert 0 < sent[8.0] < sent[0.5]
    assert list((tmp_path / "cache" / "lod").glob("*.npz"))


def test_tune_and_view_draw_the_objects_at_the_lod_of_their_tau(tmp_path):
    """tune prices each candidate's objects at their level of detail within its own tau, and
    the viewer's T key coarsens the objects with the ground (both as play does)."""
    from vismobile.app.terrain_tune import tune_terrain
    from vismobile.viewer.terrain_session import TerrainSession

    hm = sources.diamond_square(65, seed=2, roughness=0.5, relief=0.1)
    path = tmp_path / "few.vmt"
    store.save(path, hm, place_objects(hm, 3, seed=5, height=6.0))
    camera = Camera((32.0, float(hm.bounds()[1, 1]) + 20, 90.0), yaw=0, pitch=-25, fov=60,
                    aspect=240 / 320, near=0.1, far=300)
    cache = tmp_path / "cache"
    rows = {}
    for object_lod in (False, True):
        result = tune_terrain(path, [camera], methods=("tiles",), taus=(0.5, 4.0),
                              max_error_px=4.0, stages=(), structure="none",
                              object_lod=object_lod, cache_dir=cache)
        assert result["object_lod"] is object_lod
        rows[object_lod] = {r["tau"]: r["object_triangles"] for r in result["rows"]}
    full = rows[False]
    assert full[0.5] == full[4.0] > 0  # full detail whatever the tau
    assert 0 < rows[True][4.0] < rows[True][0.5] <= full[0.5]
    session = TerrainSession.open_terrain(path, "tiles", 0.5, (), "none", object_lod=True,
                                          cache_dir=cache, record_path=tmp_path / "r.csv")
    session.pose = np.array([*camera.position, camera.yaw, camera.pitch])
    fine = session.render().info["object_triangles"]
    while session.terrain.tau != 4.0:
        session.key_down("T")
    coarse = session.render().info["object_triangles"]
    assert 0 < coarse < fine
    assert "at LOD" in session.last_frame.hud[2]
    plain = TerrainSession.open_terrain(path, "tiles", 4.0, (), "none",
                                        record_path=tmp_path / "p.csv")
    plain.pose = session.pose
    assert plain.render().info["object_triangles"] > coarse  # full detail at the same tau


def test_a_terrain_with_holes_plays_with_every_method_cut(tmp_path):
    """No-data samples (seed 002's holes) through play: each method draws them cut (the hole's
    centre shows the clear colour)."""
    from vismobile.render.shaders import CLEAR_RGB
    from vismobile.terrain.heightmap import quantize

    base = sources.diamond_square(129, seed=4, roughness=0.5, relief=0.1)
    h = base.heights.astype(np.float64)
    i, j = np.mgrid[0:129, 0:129]
    h[(i - 64) ** 2 + (j - 64) ** 2 < 20 ** 2] = np.nan
    hm = quantize(h, 1.0, "lake")
    path = tmp_path / "lake.vmt"
    store.save(path, hm, place_objects(hm, 20, seed=1, height=4.0))
    top = float(np.nanmax(h))
    camera = Camera((64.0, top + 60.0, 64.0), yaw=0, pitch=-89.9, fov=30, aspect=240 / 320,
                    near=0.5, far=400)
    clear = np.rint(np.array(CLEAR_RGB) * 255)
    for method in METHODS:
        scene = TerrainScene(path, method, 1.0, ("vfc", "horizon"), "octree:3")
        f = scene.frame(camera)
        assert f.ground_triangles > 0
        image = scene.read_rgb()
        assert np.abs(image[160, 120] - clear).max() <= 1, method  # the lake's centre


@pytest.fixture(scope="module")
def holed_terrain(tmp_path_factory):
    """A steep map with no-data lakes, single samples and a one-sample gap, and objects."""
    from vismobile.terrain.heightmap import quantize

    hm = sources.diamond_square(129, seed=7, roughness=0.6, relief=0.35)
    rng = np.random.default_rng(5)
    h = hm.heights.astype(np.float64)
    i, j = np.mgrid[0:129, 0:129]
    for _ in range(6):
        ci, cj = rng.uniform(13, 116, 2)
        h[(i - ci) ** 2 + (j - cj) ** 2 < rng.uniform(3, 15) ** 2] = np.nan
    h[rng.integers(0, 129, 40), rng.integers(0, 129, 40)] = np.nan
    h[70, 25:103] = np.nan
    holed = quantize(h, 1.0, "steep-holes")
    path = tmp_path_factory.mktemp("holes") / "holes.vmt"
    store.save(path, holed, place_objects(holed, 60, seed=3, height=4.0))
    return path


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("profile", ["desktop", "fixed"])
def test_the_horizon_over_holes_hides_only_behind_drawn_ground(holed_terrain, method, profile):
    """A hole lets a ray pass below the ground without crossing it: the horizon stops a band
    at the first cut piece it has not yet covered (terrain/ground.py). Without that stop these
    cameras lose visible object triangles; with it none, and the horizon still hides."""
    import vismobile.terrain.ground as ground

    scene = TerrainScene(holed_terrain, method, 1.0, ("vfc", "horizon"), "octree:3",
                         device(profile))
    renderer = TerrainRenderer(scene.heightmap, scene.profile)
    hidden = unstopped = 0
    for camera in low_cameras(scene.heightmap, 20, seed=11):
        f = scene.frame(camera)
        assert scene.visible_dropped(camera, renderer) == 0, method
        hidden += f.triangles_hidden
        stop, ground.stop_at_cuts = ground.stop_at_cuts, lambda horizon, *args: horizon
        try:
            scene.frame(camera)
        finally:
            ground.stop_at_cuts = stop
        unstopped += scene.visible_dropped(camera, renderer)
    assert hidden > 0
    assert unstopped > 0  # these views do look through holes
