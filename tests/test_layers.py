"""The pipeline's layering: world -> partition -> culling -> render -> study (README, STYLE).
No module imports a later stage, also not lazily inside a function, so each stage can be used
and tested without the ones after it (render draws what it is given and knows no culler)."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "vismobile"
LATER = ("study", "viewer", "commands", "playback", "cli", "demo")
# package or module -> what it must not import (vismobile's own subpackages and modules)
FORBIDDEN = {
    "geometry": ("partition", "culling", "render") + LATER,
    "world": ("partition", "culling", "render") + LATER,
    "mapped": ("partition", "culling", "render") + LATER,
    "partition": ("culling", "render") + LATER,
    "culling": ("render",) + LATER,
    "render": ("culling",) + LATER,
}


def imported(path: Path, text: str | None = None) -> set:
    """First components (below vismobile) of everything the module at `path` imports, at any
    depth (text: its source, read from path when None)."""
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    names = set()
    for node in ast.walk(ast.parse(path.read_text() if text is None else text)):
        if isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the module's package
                base = list(parts[:len(parts) - node.level])
                target = base + (node.module.split(".") if node.module else [])
                if target:
                    names.add(target[0])
                else:  # `from . import x` at the package's top
                    names.update(alias.name for alias in node.names)
            elif node.module and node.module.split(".")[0] == "vismobile":
                names.add((node.module.split(".") + [""])[1])
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("vismobile."):
                    names.add(alias.name.split(".")[1])
    return names


def modules(name: str) -> list:
    folder = PACKAGE / name
    return sorted(folder.rglob("*.py")) if folder.is_dir() else [PACKAGE / f"{name}.py"]


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_no_stage_imports_a_later_one(layer):
    wrong = [f"{path.relative_to(PACKAGE)} imports {bad}" for path in modules(layer)
             for bad in sorted(imported(path) & set(FORBIDDEN[layer]))]
    assert not wrong, "; ".join(wrong)


def test_the_check_sees_lazy_relative_and_absolute_imports():
    probe = PACKAGE / "render" / "probe.py"
    text = ("import numpy as np\nfrom . import item_buffer\n\n\ndef f():\n"
            "    from ..culling.precision import margin\n    import vismobile.study.tune\n")
    assert imported(probe, text) == {"render", "culling", "study"}
    assert imported(PACKAGE / "world.py", "from .geometry import arithmetic\n") == {"geometry"}
