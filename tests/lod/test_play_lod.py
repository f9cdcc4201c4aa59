"""play with level of detail: summary.json's lod block, frames.csv's columns, the CLI."""
import json

import numpy as np
import pytest

from vismobile.app.cli import main
from vismobile.errors import VisMobileError
from vismobile.partition import partition
from vismobile.app.playback import Scene, play
from vismobile.world.trajectory import Trajectory


def walk(frames=6):
    """Backing away from the sphere: later frames reach coarser levels."""
    z = np.linspace(4.0, 40.0, frames)
    poses = np.stack([np.zeros(frames), np.full(frames, 0.5), z, np.zeros(frames),
                      np.full(frames, -2.0)], axis=1)
    return Trajectory(poses)


@pytest.fixture(scope="module")
def scene(lod_world):
    world = lod_world
    return Scene(world, partition(world, "octree", depth=3), "octree:3")


def test_play_reports_psnr_and_triangles_at_tau(scene, tmp_path):
    result = play(scene, walk(), "vfc+tbfc", "ipaq-hx2490b", tmp_path / "run", lod_tau=1.0)
    s = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert s["lod_tau"] == 1.0 and s["psnr_db_min"] > 35.0
    assert s["psnr_db_mean"] >= s["psnr_db_min"]
    assert s["triangles_sent"]["mean"] < s["triangles_full"]["mean"]
    assert "lod_buffers" in s["memory"]
    header = (tmp_path / "run" / "frames.csv").read_text().splitlines()[0].split(",")
    assert header[-5:] == ["lod_ms", "triangles_full", "psnr_db", "max_diff", "changed"]
    sent = result.frames["triangles_sent"]
    assert sent[-1] < result.frames["triangles_full"][-1]  # far: coarse levels
    # The chains were cached beside the built worlds: the next play of this world loads them.
    from vismobile.scenes.thesis import default_cache_dir

    digest = scene.world.digest().hex()[:16]
    assert (default_cache_dir() / "lod" / f"{scene.world.name}-{digest}.npz").is_file()


def test_tau_zero_plays_the_full_detail_frames(scene, tmp_path):
    s = play(scene, walk(3), "vfc", "ipaq-hx2490b", None, lod_tau=0.0).summary
    assert s["frames_identical"] == 3 and s["psnr_db_min"] is None and s["max_diff"] == 0
    assert s["triangles_sent"]["mean"] == s["triangles_full"]["mean"]


def test_lod_needs_a_partition_and_a_sane_tau(scene):
    with pytest.raises(VisMobileError, match="needs a partition"):
        play(Scene(scene.world), walk(2), (), "ipaq-hx2490b", None, lod_tau=1.0)
    with pytest.raises(VisMobileError, match="--lod-tau"):
        play(scene, walk(2), (), "ipaq-hx2490b", None, lod_tau=float("nan"))


def test_cli_partition_lod_then_play(lod_world, tmp_path, capsys):
    mesh = tmp_path / "scene.obj"
    lod_world.to_obj(mesh)
    walk().save(tmp_path / "walk.csv")
    assert main(["partition", str(mesh), "--structure", "octree:3", "--lod",
                 "-o", str(tmp_path / "s.vmp")]) == 0
    assert "lod chains" in capsys.readouterr().out
    assert main(["play", str(tmp_path / "s.vmp"), "--trajectory", str(tmp_path / "walk.csv"),
                 "--cull", "vfc", "--lod-tau", "1", "-o", str(tmp_path / "run"),
                 "--quiet"]) == 0
    assert "PSNR" in capsys.readouterr().out
    assert main(["play", str(mesh), "--trajectory", str(tmp_path / "walk.csv"),
                 "--lod-tau", "-1", "-o", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--lod-tau" in err[0]
