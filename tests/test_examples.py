"""The scripts in examples/ run as a user runs them and write what they promise."""
import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run(script, *args, cwd):
    result = subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=cwd,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_own_mesh_renders_the_built_room(tmp_path):
    out = run("own_mesh.py", "--out", "room.png", cwd=tmp_path)
    assert "World('room': 344 triangles, 3 objects" in out
    image = np.asarray(Image.open(tmp_path / "room.png").convert("RGB"))
    assert image.shape == (480, 640, 3) and len(np.unique(image.reshape(-1, 3), axis=0)) > 10


def test_own_mesh_takes_a_mesh_file(tmp_path):
    import trimesh

    trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ball.ply")
    out = run("own_mesh.py", "ball.ply", "--structure", "bsp", "--out", "ball.png", cwd=tmp_path)
    assert "World('ball': 320 triangles" in out and (tmp_path / "ball.png").is_file()


def test_compare_two_plots_both_configurations(tmp_path):
    out = run("compare_two.py", "--frames", "6", "--out", "plot.png", cwd=tmp_path)
    assert "octree" in out and "bsp" in out
    assert Image.open(tmp_path / "plot.png").size[0] > 100


def _example(name):
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_own_mesh_runs_every_structure_and_cull_its_help_shows(tmp_path, capsys):
    import re

    module = _example("own_mesh")
    try:
        module.main(["--help"])
    except SystemExit:
        pass
    text = " ".join(capsys.readouterr().out.split())
    shown = re.search(r"--structure STRUCTURE e\.g\. (.*?)(?: --|$)", text).group(1)
    structures = [s.strip() for s in shown.split(",")]
    assert {"octree:3", "grid:4", "portal:1", "bsp"} <= set(structures)
    for structure in structures:
        out = tmp_path / f"{structure.replace(':', '_').replace('=', '_')}.png"
        assert module.main(["--structure", structure, "--out", str(out)]) == 0, structure
        assert out.is_file()
    assert module.main(["--cull", "vfc+bfc+tbfc", "--out", str(tmp_path / "c.png")]) == 0
