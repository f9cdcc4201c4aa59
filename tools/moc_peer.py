"""Intel's Masked Occlusion Culling (MOC) driven hierarchically on a partition, as a peer to the
`occlusion` stage (issue 32; tools/bench_peers.py --moc). MOC is never imported by the package
or a test: its sources and ctypes binding live in ../shared/peers/moc (README there), built
with g++ into ~/.cache/moc-peer on first use.

Per frame (MocCuller.cull), the way a game drives MOC, but over the tree from its root:
  1. clear the buffer;
  2. occluders: "frustum" renders every triangle of the leaves the tree walk finds in the
     frustum (the walk against the empty buffer), "ours" the triangles the `occlusion` stage
     rasterised this frame (the same occluders, as MOC's docs advise: few, large, near);
  3. the tree walked again from the root against the buffer, hidden subtrees skipped (the
     binding's moc_test_tree: a node outside the frustum or occluded is not entered);
  4. each triangle of the surviving leaves tested on its own (back faces culled): the visible
     ones are sent.
Coordinates go to MOC in float32 relative to the world box's centre, with the camera's clip
matrix moved there (no per-frame copy of the world; float32 holds W2 and its tilings to well
under a millimetre). MOC is not conservative: it may drop what the GPU draws (rows count it).
"""
from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PEER = ROOT.parent / "shared" / "peers" / "moc"
VISIBLE = 0  # MOC's CullingResult


def unavailable() -> str | None:
    """None when MOC can be loaded (or built), else a one-line reason."""
    if not (PEER / "moc.py").exists():
        return f"MOC peer not found at {PEER} (../shared is not part of the project)"
    built = Path.home() / ".cache" / "moc-peer" / "libmoc.so"
    if not built.exists() and shutil.which("g++") is None:
        return "g++ is missing (Debian: build-essential); MOC cannot be built"
    return None


def load_moc():
    """MOC's binding module (builds libmoc.so on first use)."""
    if str(PEER) not in sys.path:
        sys.path.insert(0, str(PEER))
    import moc  # noqa: PLC0415 (a peer on ../shared, never a package import)
    return moc


def _outward32(values, down: bool) -> np.ndarray:
    """float32 of float64 values rounded outward (down for lows, up for highs)."""
    out = values.astype(np.float32)
    wrong = out > values if down else out < values
    out[wrong] = np.nextafter(out[wrong], np.float32(-np.inf if down else np.inf))
    return out


class MocCuller:
    """MOC over a partition's tree (module docstring). occluders: "frustum" or "ours" (then
    cull() takes the ids of the occluders to render). times: per-step seconds of the last
    cull, for MOC's C++ calls (walk_frustum, render, walk, triangles) and the driver's numpy
    work around them (driver)."""

    def __init__(self, tree, width: int, height: int, near: float, occluders: str = "frustum"):
        if occluders not in ("frustum", "ours"):
            raise ValueError(f"occluders must be 'frustum' or 'ours', got {occluders!r}")
        moc = load_moc()
        self.moc = moc.MOC(width, height, near=near)
        self.lib, self.handle = self.moc.lib, self.moc.handle
        self.tree, self.occluders = tree, occluders
        world = tree.world
        low, high = np.asarray(world.vertices).min(0), np.asarray(world.vertices).max(0)
        self.origin = 0.5 * (low + high)
        self.vertices = np.ascontiguousarray(np.asarray(world.vertices) - self.origin, np.float32)
        self.triangles = np.ascontiguousarray(world.triangles, np.uint32)
        self.lo = np.ascontiguousarray(_outward32(tree.lo - self.origin, True))
        self.hi = np.ascontiguousarray(_outward32(tree.hi - self.origin, False))
        self.first_child = np.ascontiguousarray(tree.first_child, np.int32)
        self.child_count = np.ascontiguousarray(
            np.where(tree.nonempty, tree.child_count, 0), np.int32)
        self.leaf_mark = np.empty(tree.node_count, np.uint8)
        self.times = {}
        self.tested = 0

    def clip(self, camera) -> np.ndarray:
        """(4, 4) float32 column-major clip matrix from coordinates relative to self.origin."""
        move = np.eye(4)
        move[:3, 3] = self.origin
        return np.ascontiguousarray((camera.view_projection() @ move).T, np.float32)

    def _walk(self, matrix) -> np.ndarray:
        """Leaves reached by MOC's hierarchical walk (moc_test_tree) against the buffer."""
        self.tested += self.lib.moc_test_tree(
            self.handle, self.lo.ctypes.data, self.hi.ctypes.data, self.first_child.ctypes.data,
            self.child_count.ctypes.data, len(self.lo), matrix.ctypes.data,
            self.moc.near, self.leaf_mark.ctypes.data)
        return np.flatnonzero(self.leaf_mark)

    def cull(self, camera, ours=None) -> np.ndarray:
        """(S,) int64 sorted triangle ids MOC finds visible from camera."""
        t, times = time.perf_counter, self.times
        start = t()
        self.tested = 0
        if camera.near != self.moc.near:
            raise ValueError(f"MOC was set up for near {self.moc.near}, camera has {camera.near}")
        self.lib.moc_clear(self.handle)
        matrix = self.clip(camera)
        driver = t() - start
        if self.occluders == "frustum":
            a = t()
            leaves = self._walk(matrix)
            times["walk_frustum"] = t() - a
            a = t()
            ids = self.tree.gather(leaves)[0]
            occluders = self.triangles[ids]
            driver += t() - a
        else:
            times["walk_frustum"] = 0.0
            a = t()
            occluders = self.triangles[np.asarray(ours, dtype=np.int64)]
            driver += t() - a
        a = t()
        self.lib.moc_render(self.handle, self.vertices.ctypes.data, occluders.ctypes.data,
                            len(occluders), matrix.ctypes.data, self.moc.BACKFACE_CW)
        times["render"] = t() - a
        a = t()
        leaves = self._walk(matrix)
        times["walk"] = t() - a
        a = t()
        ids = self.tree.gather(leaves)[0]
        tests = np.ascontiguousarray(self.triangles[ids])
        result = np.empty(len(ids), np.uint8)
        driver += t() - a
        a = t()
        self.lib.moc_test_each(self.handle, self.vertices.ctypes.data, tests.ctypes.data,
                               len(tests), matrix.ctypes.data, self.moc.BACKFACE_CW,
                               result.ctypes.data)
        times["triangles"] = t() - a
        a = t()
        sent = ids[result == VISIBLE]
        times["driver"] = driver + t() - a
        times["occluders"] = len(occluders)
        times["tested"] = len(ids)
        return sent
