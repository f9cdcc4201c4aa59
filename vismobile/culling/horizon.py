"""`horizon`: a 2.5D occlusion horizon for object worlds (Downs, Möller and Séquin 2001), cast
each frame front to back over the ground-standing occluders found in the geometry (buildings,
walls, grounds: culling/horizon_solids.py) with the terrain horizon's caster
(terrain/horizon_cells.py over terrain/horizon.py's kernels), then node boxes and triangles are
tested against it.

Contract: never drops a triangle that a pixel shows, from any eye and pitch. A box is hidden
only when every ray from the eye to it passes, in a slice wholly beyond the near plane's reach,
through a solid column between its base and top, after passing above every solid near the eye;
the ray then enters the solid through one of its drawn, outward faces in front of the box. Where
that argument fails it hides nothing: the eye at or below a solid's top next to it (inside a
building, under the ground), below a free-standing prism's open bottom, or no occluder found.
Footprints shrink, tops sink, highs and bases rise, boxes grow by twice the device's vertex
move (precision.device_move); on fixed16.16 the cast and the test run in 16.16 integers.

Triangles are also dropped when wholly off screen (all three corners outside one frustum plane,
the Culler's planes pushed out as vfc's are, plus the device's move): the horizon covers the
screen only, and vfc hands on whole leaves that straddle the frustum (the kd-tree's: W5 outdoor,
91 of its 120 unseen triangles sent a frame were off screen). With no horizon cast (the eye
inside or under a solid) this test still runs.

Before its triangles, each object's box (grown as their corners are) is tested once a frame,
off screen and behind the horizon; a box that is goes with all its triangles, which lie in it
(the terrain world of 200 models: 90% of the triangles tested are decided by their box).

With `screen` (the device's width, height) a triangle is also dropped when it covers no pixel
centre of that screen (occlusion's test, hiz._covers_no_sample: corners moved by the device's
rounding, 1/64 pixel slack): safe at that resolution without multisampling only (the item
buffer's), so it is off unless the caller says. On W6's outdoor path most of what the horizon
keeps and no pixel shows is such triangles (octree 5: 190 of 308 a frame).
"""
from __future__ import annotations

import numpy as np

from ..terrain.horizon import Horizon
from ..terrain.horizon_cells import CellCaster
from .backface import half_tangents
from .horizon_tests import (NO_HORIZON, NO_SCREEN, _nodes, _triangles, fixed_arrays,
                            horizon_arrays)
from .horizon_solids import MAX_CELLS, find_solids, solid_map
from .precision import DEVICE_ABSOLUTE, DEVICE_RELATIVE, device_move, world_scale
from .shared import per_object
from .state import CullState
from .tree import Tree


def object_boxes(world) -> np.ndarray:
    """(O, 2, 3) float64 box of each object's triangles (object ids 0..O-1; empty: inverted)."""
    ids = np.asarray(world.object_ids, dtype=np.int64)
    count = int(ids.max()) + 1 if len(ids) else 0
    boxes = np.empty((count, 2, 3))
    boxes[:, 0], boxes[:, 1] = np.inf, -np.inf
    np.minimum.at(boxes[:, 0], ids, world.bounds[:, 0])
    np.maximum.at(boxes[:, 1], ids, world.bounds[:, 1])
    return boxes


class HorizonStage:
    """`horizon`: drops node subtrees, then triangles, hidden behind the occlusion horizon.

    bands     : horizontal direction bands across the frustum (more: tighter, slower cast;
                32 measured best: W5 outdoor octree 4 sends 0.347x of vfc+tbfc in 0.69x
                occlusion's time, against 0.306x in 1.08x with 64)
    step      : slice growth per step (depth slices z_{k+1} = z_k (1 + step))
    triangles : also test each sent triangle (after the node tests): off screen, or its
                corners' hull behind the horizon
    cells     : largest side of the occluder map (cells)
    screen    : (width, height) of the device's screen, or None: also drop triangles that
                cover no pixel centre of it (see the module doc; safe at that resolution only)
    """

    name = "horizon"
    cost = 87  # after tbfc (85): its filter then tests front faces only
    arithmetic = "float64"  # the Culler sets its mode: fixed16.16 casts in 16.16

    def __init__(self, bands: int = 32, step: float = 0.01, triangles: bool = True,
                 cells: int = MAX_CELLS, screen=None):
        if isinstance(bands, bool) or not isinstance(bands, (int, np.integer)) or bands < 1:
            raise ValueError(f"horizon bands must be a positive integer, got {bands!r}")
        if not isinstance(step, (int, float)) or not 1e-4 <= step <= 1.0:
            raise ValueError(f"horizon step must be from 1e-4 to 1, got {step!r}")
        if isinstance(cells, bool) or not isinstance(cells, (int, np.integer)) \
                or not 1 <= cells <= 4096:
            raise ValueError(f"horizon cells must be an integer from 1 to 4096, got {cells!r}")
        self.bands, self.step, self.cells = int(bands), float(step), int(cells)
        self.triangles = bool(triangles)
        self.screen = None if screen is None else tuple(int(v) for v in screen)
        if self.screen is not None and (len(self.screen) != 2 or min(self.screen) < 1):
            raise ValueError(f"horizon screen must be (width, height) > 0, got {screen!r}")

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        world = tree.world
        self.margin = 2.0 * np.sqrt(3.0) * device_move(self.arithmetic,
                                                        world_scale(world.vertices))
        # A terrain world brings its ground (terrain/ground.py): the heightmap occludes.
        self.ground = getattr(world, "ground", None)
        if self.ground is None:
            self.solids = per_object(world, "horizon solids", lambda: find_solids(world))
        self.bounds = world.bounds
        self.corners = world.corners
        self.grow = np.array([-self.margin, self.margin])[:, None]
        self.magnitude = world_scale(world.vertices)
        # Each object's box, grown as the triangles' corners are: the triangle kernels test it
        # once a frame, before its triangles (stamp, verdict: kept between frames).
        self.object_ids = np.ascontiguousarray(world.object_ids, dtype=np.int32)
        self.object_boxes = per_object(world, "horizon object boxes",
                                       lambda: object_boxes(world)) + self.grow
        self.stamp = np.zeros(len(self.object_boxes), np.int64)
        self.verdict = np.zeros(len(self.object_boxes), np.int8)
        self.frame = 0

    def objects(self) -> tuple:
        """_triangles' object arguments for a new frame (horizon_tests.NO_OBJECTS' order)."""
        self.frame += 1
        return self.object_ids, self.object_boxes, self.stamp, self.verdict, self.frame

    def samples(self, camera) -> tuple:
        """_triangles' screen arguments (eye, rotation, near, tx, ty, width, height, move) for
        the pixel-centre test, or NO_SCREEN: occlusion's corner move (twice the device's, at
        least DEVICE_RELATIVE x the scale with the eye plus DEVICE_ABSOLUTE)."""
        if self.screen is None:
            return NO_SCREEN
        tx, ty = half_tangents(camera.fov, camera.aspect)
        scale = max(self.magnitude, *map(abs, camera.position))
        move = max(DEVICE_RELATIVE * scale + DEVICE_ABSOLUTE,
                   2.0 * device_move(self.arithmetic, scale))
        return (np.asarray(camera.eye, np.float64), np.array(camera.axes(), np.float64),
                float(camera.near), tx, ty, *self.screen, move)

    def caster(self, valid):
        """(SolidMap, CellCaster) with the grounds `valid` counted (built once per set, per
        world: an eye is over one ground or a few), or (None, None) with no solid."""
        world, fixed = self.tree.world, self.arithmetic == "fixed16.16"

        def build():
            solids = solid_map(world, self.solids, valid, self.margin, self.cells)
            if solids is None:
                return None, None
            return solids, CellCaster(solids.tops, solids.highs, solids.bases, solids.origin,
                                      solids.spacing, self.bands, self.step,
                                      "fixed16.16" if fixed else "float64",
                                      f"world {world.name}")

        key = ("horizon caster", valid, self.margin, self.cells, self.bands, self.step, fixed)
        return per_object(world, key, build)

    def cast(self, camera):
        """This frame's horizon, or None when it may hide nothing (see the module doc)."""
        if self.ground is not None:
            return self.ground.cast(camera, self.arithmetic)
        eye = np.asarray(camera.eye, dtype=np.float64)
        solids, caster = self.caster(self.solids.grounds_under(eye, self.margin))
        if caster is None or not eye[1] > solids.max_base + self.margin:
            return None
        return caster.cast(camera)

    def apply(self, state: CullState) -> None:
        horizon = self.cast(state.camera)
        tree = self.tree
        if horizon is None:
            state.count(f"{self.name}.skipped", 1)
        else:
            # vfc's nodes as it hands them on (covered nodes whole: walking them to their
            # leaves culled more but cost more: W5 outdoor, 120 frames, octree 5 sent 0.466x
            # of vfc+tbfc at 0.85x occlusion's time, against 0.479x at 0.70x as here); then the
            # triangles.
            nodes = state.nodes[tree.nonempty[state.nodes]]
            if isinstance(horizon, Horizon):  # float64: one numba call
                hidden = _nodes(tree.node_bounds, nodes, self.margin, *horizon_arrays(horizon))
            else:
                hidden = horizon.hidden(tree.node_bounds[nodes] + self.grow)
            tested = len(nodes)
            state.count(f"{self.name}.nodes_culled", hidden.sum())
            state.nodes = nodes[~hidden]
            state.count("nodes_visited", tested)
            state.count(f"{self.name}.nodes_tested", tested)
            # bands x slices cast (up to the early stops; all of them when not counted)
            state.count(f"{self.name}.pieces",
                        horizon.pieces if horizon.pieces >= 0 else horizon.values.size)
        if self.triangles:
            stats, key = state.stats, f"{self.name}.triangles_"
            planes, slack = state.planes, tree.tol + self.margin
            samples = self.samples(state.camera)

            def keep_of(ids):  # holds the stats dict, not the state (no cycle)
                objects = self.objects()
                if isinstance(horizon, Horizon):  # float64: one numba call
                    arrays = horizon_arrays(horizon)
                elif horizon is not None:  # fixed16.16: one numba call too
                    arrays = fixed_arrays(horizon)
                else:  # no horizon cast: off screen and centres
                    arrays = NO_HORIZON
                off, behind, sub = _triangles(self.corners, ids, planes, slack, self.margin,
                                              *arrays, *samples, *objects)
                stats[key + "off_screen"] = stats.get(key + "off_screen", 0) + int(off.sum())
                stats[key + "culled"] = stats.get(key + "culled", 0) + int(behind.sum())
                stats[key + "subpixel"] = stats.get(key + "subpixel", 0) + int(sub.sum())
                if self.screen is not None:  # what reached the centre test (device model)
                    stats[key + "centre_tested"] = (stats.get(key + "centre_tested", 0)
                                                    + len(ids) - int((off | behind).sum()))
                stats[key + "tested"] = stats.get(key + "tested", 0) + len(ids)
                return ~(off | behind | sub)

            state.filters.append(keep_of)
