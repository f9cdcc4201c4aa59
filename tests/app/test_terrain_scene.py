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


def drawn_ground_items(scene, selected, renderer, camera):
    """Item-draw the ground the method selected (ids below the objects')."""
    lod = scene.lod
    if lod.name == "tiles":
        from vismobile.terrain.tiles import selection_mesh

        stats = renderer.draw(*selection_mesh(lod.pyramid, selected), camera, kind="item")
    elif lod.name == "roettger":
        stats = renderer.draw_samples(lod.lists.sample_triangles(selected), camera, kind="item")
    else:
        stats = renderer.draw_samples(selected.triangles, camera, kind="item")
    return stats.triangles


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("profile", ["desktop", "ipaq-hx2490b"])
def test_horizon_never_hides_a_visible_object_triangle(terrain, method, profile):
    scene = TerrainScene(terrain, method, 1.0, ("vfc", "horizon"), "octree:3", profile)
    renderer = TerrainRenderer(scene.heightmap, scene.profile)
    objects = scene.objects
    hidden_total = 0
    for camera in low_cameras(scene.heightmap, 12, seed=len(method) + len(profile)):
        f = scene.frame(camera)
        assert f.error_px <= 1.0 + 1e-9
        kept = np.zeros(objects.triangle_count, bool)
        kept[scene.culled.triangles] = True
        selected = scene.last
        first = drawn_ground_items(scene, selected, renderer, camera)
        renderer.draw_mesh_items(objects.vertices, objects.triangles, camera, first)
        ids = renderer.read_ids().ravel()
        seen = np.unique(ids[(ids >= first) & (ids < first + objects.triangle_count)]) - first
        assert kept[seen].all(), f"{method}: {int((~kept[seen]).sum())} visible triangles dropped"
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
                 "-o", str(out)]) == 0
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


def test_a_terrain_with_holes_plays_with_every_method_and_hides_nothing(tmp_path):
    """No-data samples (seed 002's holes) through play: each method draws them cut (the hole's
    centre shows the clear colour) and the horizon hides nothing over such a terrain."""
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
        assert f.ground_triangles > 0 and f.nodes_hidden == f.triangles_hidden == 0
        image = scene.read_rgb()
        assert np.abs(image[160, 120] - clear).max() <= 1, method  # the lake's centre
