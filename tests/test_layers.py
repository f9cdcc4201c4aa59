"""The package's layering (README, STYLE): every module belongs to a layer, and imports only from
layers below its own, also lazily inside a function, so each stage can be used and tested
without the ones above it (render draws what it is given and knows no culler). No import
circle among vismobile's modules, and at most 8 modules at the package root."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "vismobile"
# Layers from the bottom up; a unit (a subpackage, a module, or a module inside a subpackage,
# the longest match wins) imports only units of a strictly lower layer, or itself.
LAYERS = (
    # leaves any module may use; the package's __init__ looks its public names up by string
    ("__init__", "errors", "stats", "progress", "timing", "open3d_import"),
    ("files",),                    # atomic writes, OBJ and the other mesh formats
    ("device",),                   # profiles, fixed point, the cost model
    ("geometry",),                 # predicates with error contracts
    ("world",),                    # the scene model: world, camera, trajectory, mapped worlds
    ("scenes",),                   # the thesis worlds and their objects
    ("terrain",),                  # heightmap worlds
    # a world file dispatched on its type (above world, terrain); level-of-detail chains and
    # their per-frame selection (lod/, reads terrain's pixel scale)
    ("files.loader", "lod"),
    ("partition",),
    ("culling", "render"),         # side by side: neither imports the other
    ("study",),
    ("app",),                      # demo, playback, walk
    ("viewer",),
    ("commands",),
    ("app.cli",),                  # the entry point: parses and runs the commands
    ("__main__",),
)
MAX_ROOT_MODULES = 8


def module_name(path: Path, package: Path = PACKAGE) -> str:
    """Dotted name below the package ("partition.base"; "partition" for its __init__)."""
    parts = path.relative_to(package).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, known: set, package: Path = PACKAGE, text: str | None = None) -> set:
    """Modules of `known` (dotted names below the package, "__init__" for its top) that the
    module at `path` imports, at any depth (inside functions too), relative or absolute.
    `from P import x` names module P.x when that is a module, else P itself. A module that does
    not exist is named "missing:<dotted name>" (text: the source, read from path when None)."""
    parts = path.relative_to(package).with_suffix("").parts
    here = list(parts[:-1])  # the package the module is in (an __init__ is its own package)
    found = set()

    def add(dotted: str, names=()):
        dotted = dotted or "__init__"
        if dotted not in known:
            found.add(f"missing:{dotted}")
            return
        for name in names:
            below = f"{dotted}.{name}" if dotted != "__init__" else name
            found.add(below if below in known else dotted)
        if not names:
            found.add(dotted)

    for node in ast.walk(ast.parse(path.read_text() if text is None else text)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[:len(here) - (node.level - 1)] if node.level > 1 else here
                target = ".".join(base + (node.module.split(".") if node.module else []))
            elif node.module and node.module.split(".")[0] == package.name:
                target = node.module.partition(".")[2]
            else:
                continue
            add(target, [alias.name for alias in node.names])
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith(package.name + "."):
                    add(alias.name.partition(".")[2])
    return found - {module_name(path, package)}


def graph(package: Path = PACKAGE) -> dict:
    """{module: set of modules it imports} over every module of the package."""
    paths = {module_name(p, package) or "__init__": p for p in sorted(package.rglob("*.py"))}
    known = set(paths)
    return {name: imports(path, known, package) for name, path in paths.items()}


def cycles(edges: dict) -> list:
    """Every import circle: the strongly connected components of more than one module
    (Tarjan, iterative), each as a sorted list."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    counter = 0
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in edges:
                    continue
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def layer(module: str) -> tuple:
    """(layer index, unit) of a module: the longest unit of LAYERS that is it or contains it."""
    best = None
    for rank, units in enumerate(LAYERS):
        for unit in units:
            if (module == unit or module.startswith(unit + ".")) and (
                    best is None or len(unit) > len(best[1])):
                best = (rank, unit)
    return best


def upward(edges: dict) -> list:
    """"a imports b" for every import of a unit that is not in a lower layer."""
    wrong = []
    for module, targets in sorted(edges.items()):
        rank, unit = layer(module)
        for target in sorted(targets):
            other = layer(target)
            if target.startswith("missing:"):
                wrong.append(f"{module} imports {target[len('missing:'):]}, which does not exist")
            elif other is None:
                wrong.append(f"{module} imports {target} (not in a layer)")
            elif other[1] != unit and other[0] >= rank:
                wrong.append(f"{module} imports {target}")
    return wrong


def test_every_module_is_in_a_layer():
    missing = [m for m in graph() if layer(m) is None]
    assert not missing, f"add these to LAYERS: {missing}"


def test_no_import_circles():
    found = cycles(graph())
    assert not found, "; ".join(" <-> ".join(c) for c in found)


def test_no_module_imports_a_later_layer():
    wrong = upward(graph())
    assert not wrong, "; ".join(wrong)


def test_at_most_eight_modules_at_the_package_root():
    root = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(root) <= MAX_ROOT_MODULES, root


def test_the_check_sees_lazy_relative_and_absolute_imports():
    known = set(graph())
    probe = PACKAGE / "render" / "probe.py"
    text = ("import numpy as np\nfrom . import item_buffer\n\n\ndef f():\n"
            "    from ..culling.precision import margin\n    import vismobile.study.tune\n"
            "    from .. import progress\n    from ..partition import partition\n")
    assert imports(probe, known, text=text) == {"render.item_buffer", "culling.precision",
                                                 "study.tune", "progress", "partition"}
    assert imports(PACKAGE / "world" / "world.py", known,
                   text="from ..geometry import arithmetic\n") == {"geometry.arithmetic"}
    # a relative import that resolves to nothing (a module moved without its imports)
    assert imports(PACKAGE / "app" / "cli.py", known,
                   text="def f():\n    from .commands import options\n") == {"missing:app.commands"}


def write_package(folder: Path, files: dict) -> Path:
    package = folder / "vismobile"
    for name, text in files.items():
        path = package / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return package


def test_the_checks_fail_on_a_lazy_circle_and_an_upward_import(tmp_path):
    package = write_package(tmp_path, {
        "__init__.py": "",
        "partition/__init__.py": "",
        "partition/base.py": "def save():\n    from .store import write\n",  # lazy
        "partition/store.py": "from .grid import cells\n",
        "partition/grid.py": "from .base import save\nfrom ..culling import frustum\n",
        "culling/__init__.py": "",
        "culling/frustum.py": "from vismobile.partition import base  # downward: allowed\n",
        "render/__init__.py": "",
        "render/draw.py": "def f():\n    from ..culling.frustum import x\n",
    })
    edges = graph(package)
    # the upward import closes a second way round: both are in the one circle found
    assert cycles(edges) == [["culling.frustum", "partition.base", "partition.grid",
                              "partition.store"]]
    assert upward(edges) == ["partition.grid imports culling.frustum",
                             "render.draw imports culling.frustum"]
    del edges["partition.grid"]
    assert cycles(edges) == []


@pytest.mark.parametrize("module, expected", [("files.atomic", (1, "files")),
                                              ("files.loader", (7, "files.loader")),
                                              ("culling.hiz", (9, "culling")),
                                              ("render.terrain", (9, "render"))])
def test_layers_take_the_longest_unit(module, expected):
    assert layer(module) == expected
