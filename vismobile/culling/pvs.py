"""`pvs`: precomputed visibility (partition/pvs.py) looked up per frame.

The stage finds the view cells holding the eye (grown by the device's reach) and hands on only
their sets: the draw nodes become the topmost subtrees whose leaves all hold a triangle of the
set (or none at all), and a triangle filter keeps the set's triangles. The stored sets
(partition/pvs_codec.py) are inflated once when the stage is prepared; a cell's set is then
one gather of its pattern bits, done per combination of cells (on a boundary) and kept (KEEP
combinations); a frame's own work is the cell lookup and the filter over what is gathered,
nothing proportional to the world. When vfc is the only node stage after it (static
partition), lookup, the face-plane test, vfc's walk over the set's subtrees, gather and filter
run in one compiled call instead (pvs_frame.py, apply_fused), which finds the set in the last
KEEP combinations' slots (allow bytes and kept bits), so a frame on a combination met before
runs no Python past the call: the same triangles. No free-space
test: the cells taken are all those within the near plane's reach (plus the device's) of the
eye, since sight lines start on the near plane, perhaps beyond a wall next to the eye; the bake
put the inside of every solid near a cell in its set (partition/pvs.py).

Hands on everything when the cells see the whole world (`pvs.everything`); falls back (hands
on everything, counted in `pvs.fallbacks`) when the partition holds no PVS, the eye is in no
view cell, its near plane is within the device's move, or the device's reach exceeds the
bake's growth, or (a bake without pvs_plane) the eye lies in a cell face's plane
(pvs_frame.near_plane);
and with street-level cells (partition/pvs_street.py, `pvs_cover`: they cover
only where a camera walks), when the near plane is nearer than the bake assumed or reaches
farther from the eye than it assumed, or may leave the cells (an eye near the top of the
layer, above it, or by a building's inside: `covered`).

The sets are stored whole; with a back-face stage in the combination (the Culler sets
back_culled) and the eye within pvs_back of every cell taken, each cell's set loses what faces
away from the whole cell grown by pvs_back (partition/pvs_back.py, computed when the cells'
union is decoded), which GL_CULL_FACE would cull anyway.

Doors (issue 25): a PVS baked from an AnimatedWorld with doors keeps, per view cell and door,
what the door shut hides from the cell (partition/pvs.py door_sets). Each frame the doors that
are shut for this eye (culling/doors.shut: closed, the eye outside the box beyond the near
plane's reach) take their sets out of each cell's: a line from the eye through a shut door's
portal meets the door first, so what only such lines reach is hidden (several shut doors:
each one's set comes out, a subset of what they hide together). `pvs.doors_shut` counts them.

Contract: with pvs=sampled:N (render/pvs_sampled.py) aggressive, it misses what no sample
point saw. With pvs=conservative: conservative against the item buffer without back-face
culling, for eyes it does not fall back on, as partition/pvs.py bakes it (the portals'
contract); with back faces culled, against the back-face-culled item buffer with the portals'
known limit (a one-sided wall lying in a cell face, seen from behind: an eye on or inside a
hollow wall or slab sees through the backs of its faces).
"""
from __future__ import annotations

import math
from functools import partial

import numpy as np

from ..partition.pvs import back_delta, ids_of
from ..partition.pvs_back import region_backfacing, triangle_terms
from ..partition.pvs_codec import cell_mask, decode
from ..partition.pvs_planes import face_sets
from .doors import closed_doors, shut
from .precision import device_move, world_scale
from .pvs_frame import (KEY_CELLS, TABLE_FIELDS, keep_bits, locate_walk_gather, near_plane,
                        pack_tables)
from .pvs_lookup import cell_index, find
from .state import CullState
from .tree import Tree

EXTRAS = ("pvs_cells", "pvs_shape", "pvs_pack", "pvs_grow")
KEEP = 64  # decoded cell combinations kept (and slots of the fused call's)
# how far from a cell face's plane (in the device's reach) an eye falls back: past the
# device's rounding of the eye, a wall in the plane shows a sliver (pvs_frame.near_plane)
FACE_REACH = 4.0


class PVSStage:
    """`pvs`: the eye's view-cell set from the baked PVS; runs before the other node stages.

    fuse : when vfc is the only node stage after it (static partition), walk the frustum over
           the set's subtrees, gather and filter in one compiled call (pvs_frame.py; the
           Culler sets `walker`, the vfc stage, whose options the walk takes); False: hand on
           the set's topmost nodes and a filter, and let vfc walk them (the same triangles)
    """

    name = "pvs"
    cost = 4
    arithmetic = "float64"

    def __init__(self, fuse: bool = True):
        if not isinstance(fuse, (bool, np.bool_)):
            raise ValueError(f"pvs fuse must be True or False, got {fuse!r}")
        self.fuse = bool(fuse)
        self.walker = None
        self.gather = True  # the fused call gathers (vfc the last node stage); the Culler sets
        # False when occlusion follows: the call then walks, occlusion tests and gathers
        self.keep = KEEP  # the fused call's slots at most (sets it walks without Python)

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        # the fused call's scratch (pvs_frame.locate_walk_gather): walk, gather, counters
        self.scratch = np.empty((4, tree.node_count + 1), dtype=np.int64)
        self.ranges = np.empty((tree.node_count + 1, 2), dtype=np.int64)
        self.counts = np.zeros(12, dtype=np.int64)
        self.tables = None  # the fused call's FrameTables, packed on its first frame
        self.forget()
        self.memo = (None, None)  # reaches' last (near, fov, aspect) and result
        extras = tree.partition.extras or {}
        self.available = all(k in extras for k in EXTRAS)
        self.cache = {}
        self.faces = None
        self.face_coords, self.face_start = np.zeros(0), np.zeros(4, dtype=np.int64)
        if not self.available:
            return
        self.cells = np.ascontiguousarray(extras["pvs_cells"], dtype=np.float64)
        # portal-walk cells: the coordinates of their faces, per axis (near_plane), unless the
        # bake walked the lines in the grid's face planes (pvs_planes.py) for eyes within
        # pvs_plane: an eye that near one of the planes walked takes the cells' face sets too
        self.faces = None if "pvs_cover" in extras else \
            packed_planes([np.unique(self.cells[:, :, a]) for a in range(3)])
        self.plane = self.face_planes = self.face_patterns = None
        if "pvs_plane" in extras:
            self.plane = float(np.asarray(extras["pvs_plane"])[0])
            rows = np.asarray(extras["pvs_face_planes"], dtype=np.float64).reshape(-1, 2)
            self.face_planes = [np.sort(rows[rows[:, 0] == a, 1]) for a in range(3)]
            sets = face_sets(extras)
            if sets is not None:
                self.face_patterns, self.face_ids = decode(sets, len(self.cells),
                                                           tree.world.triangle_count)
                # the planes walked, per axis, for the compiled test (pvs_frame.near_plane)
                self.face_coords, self.face_start = packed_planes(self.face_planes)
        self.index = cell_index(self.cells)  # x-z buckets: a frame tests the cells near the eye
        self.tested = 0
        # inflated once, here (the load checked it): K pattern bitsets, a pattern per triangle
        self.patterns, self.ids = decode(extras, len(self.cells), tree.world.triangle_count)
        self.terms = None  # triangle_terms for the back-face test, made on first use
        self.grow = float(np.asarray(extras["pvs_grow"])[0])
        # street-level cells (partition/pvs_street.py) hold what lines from within cover of
        # them see, for near planes from near_min: (cover, near_min), else None
        self.cover = tuple(float(v) for v in np.asarray(extras["pvs_cover"])) \
            if "pvs_cover" in extras else None
        # a sampled PVS (render/pvs_sampled.py) is aggressive: no growth to check against
        self.sampled = str(tree.partition.params.get("pvs", "")).startswith("sampled")
        self.magnitude = world_scale(tree.world.vertices)
        # the sets leave out what faces away from a whole cell grown by pvs_back (the bake's
        # from-region back-face test): without back-face culling those go back in
        self.back = float(np.asarray(extras["pvs_back"])[0]) if "pvs_back" in extras else None
        self.back_culled = False  # set by the Culler: a back-face stage is in the combination
        # what each shut door hides from each cell (partition/pvs.py door_sets), if baked
        self.door_boxes = np.asarray(extras["pvs_door_boxes"], dtype=np.float64) \
            if "pvs_door_boxes" in extras else None
        self.door_ok = False  # use_doors: the world's doors are the baked ones
        self.door_matrices = None  # this frame's door matrices (D, 4, 4), set by the Culler

    def use_doors(self, boxes) -> None:
        """The animated world's doors (culling/doors.attach_doors), rest boxes (D, 2, 3) in
        the order of the matrices the Culler hands on: their sets are used only when they are
        the doors the bake kept (same boxes, same order)."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
        self.door_ok = self.door_boxes is not None and boxes.shape == self.door_boxes.shape \
            and bool(np.array_equal(boxes, self.door_boxes))

    def shut_doors(self, camera, grow: float, reach: float) -> tuple:
        """Sorted door ids whose sets leave this frame's (culling/doors.shut: closed, the eye
        outside the box grown by the near plane's reach, the device's and what the door may
        have moved; the portals' depth was checked at the bake, at its growth)."""
        if not self.door_ok or self.door_matrices is None or self.sampled:
            return ()
        closed, slack = closed_doors(self.door_matrices)
        scale = max(self.magnitude, float(np.abs(camera.eye).max()))
        return tuple(int(d) for d in np.flatnonzero(
            shut(self.door_boxes, closed, slack * (scale + 1.0), camera.eye, reach + grow)))

    def reach(self, camera) -> float:
        """2 sqrt(3) device_move at the world's and the eye's magnitude (portals.device_reach)."""
        x, y, z = camera.position
        scale = max(self.magnitude, abs(x), abs(y), abs(z))
        return 2.0 * math.sqrt(3.0) * device_move(self.arithmetic, scale)

    def eye_cells(self, camera, grow: float) -> np.ndarray:
        """(K,) int64 view cells whose box grown by the tree's slack plus grow holds the eye
        (a superset of the cells within grow of the eye: boxes grown, not rounded), from the
        buckets around the eye (pvs_lookup.py; self.tested: the boxes tested)."""
        found, self.tested = find(self.cells, *self.index, np.asarray(camera.eye, np.float64),
                                  self.tree.tol + grow)
        return found

    def visible(self, cells, drop_back=True, doors=(), face=False) -> tuple:
        """(keep (T,) bool, draw nodes (D,) int64, everything: bool) of the union of the
        cells' sets, cached; with drop_back (and a pvs_back) each cell's set loses the
        triangles facing away from the whole cell grown by pvs_back (partition/pvs_back.py);
        and what each door of `doors` (shut) hides from it (door sets); with face, each cell's
        face set joins it (what lines lying in a face's plane add: pvs_planes.py)."""
        return self.entry(cells, drop_back, doors, face)[:3]

    def entry(self, cells, drop_back=True, doors=(), face=False) -> tuple:
        """visible's three, plus what the fused walk reads (pvs_frame.walk_gather): allow (N,)
        bool, the nodes whose subtree holds a kept triangle, and the kept bits (T // 64 + 1,)
        uint64; cached together (KEEP combinations)."""
        drop = self.back is not None and drop_back
        face = bool(face) and self.face_patterns is not None
        key = (np.asarray(cells, dtype=np.int64).tobytes(), drop, tuple(doors), face)
        hit = self.cache.get(key)
        if hit is not None:
            return hit
        if len(self.cache) >= KEEP:
            self.cache.pop(next(iter(self.cache)))
        self.cache[key] = self.make_entry(cells, drop, doors, face)
        return self.cache[key]

    def make_entry(self, cells, drop, doors, face) -> tuple:
        """entry's five, made (not cached); self.decoded: the pattern ids gathered."""
        tree = self.tree
        keep = np.zeros(tree.world.triangle_count, dtype=bool)
        self.decoded = 0  # pattern ids gathered (the device model prices a cache miss by them)
        extras = tree.partition.extras
        for c in cells:
            mask = cell_mask(self.patterns, self.ids, int(c))
            self.decoded += len(self.ids)
            if face:
                mask |= cell_mask(self.face_patterns, self.face_ids, int(c))
                self.decoded += len(self.face_ids)
            if drop:
                if self.terms is None:
                    self.terms = triangle_terms(tree.world.corners)
                lo, hi = self.cells[c]
                held = np.flatnonzero(mask)
                mask[held[region_backfacing(None, lo - self.back, hi + self.back,
                                            back_delta(tree.world), self.terms, held)]] = False
            for d in doors:  # what a shut door hides from this cell, whichever way it faces
                k = int(c) * len(self.door_boxes) + d
                start = extras["pvs_door_start"]
                mask[ids_of(extras["pvs_door_runs"][start[k]:start[k + 1]])] = False
            keep |= mask
        nodes, allow = set_nodes(tree, keep)
        return keep, nodes, bool(keep.all()), allow, keep_bits(keep)

    def forget(self) -> None:
        """Drop every decoded set: entry's cache and the fused call's slots."""
        self.cache = {}
        self.slot_key = self.slot_allow = self.slot_kept = None
        self.filled = 0  # slots written so far (round robin once all self.keep are)
        self.tables = None

    def fill(self, found, drop: bool, face: bool) -> None:
        """Make the set of the cells found (drop_back drop, face sets face) and write it in
        the fused call's next slot (pvs_frame.find_slot's key row, allow and kept bits):
        slots grow 8, 16, .. up to self.keep, then the oldest is overwritten; wider key rows
        when more cells are found than they hold. Costs a decode (make_entry), once per new
        combination, not per frame."""
        _, _, everything, allow, bits = self.make_entry(found, drop, (), face)
        key = self.slot_key if self.filled else None  # (frame's placeholder: no slot)
        cap, width = (0, 0) if key is None else (len(key), key.shape[1] - KEY_CELLS)
        grow = self.filled >= cap and cap < self.keep
        if grow or len(found) > width:
            size = min(self.keep, max(8, 2 * cap)) if grow else cap
            wide = max(width, len(found), 4)
            new_key = np.zeros((size, KEY_CELLS + wide), dtype=np.int64)
            new_allow = np.zeros((size, len(allow)), dtype=bool)
            new_kept = np.zeros((size, len(bits)), dtype=np.uint64)
            if key is not None:  # the slots so far keep their rows
                new_key[:cap, :key.shape[1]] = key
                new_allow[:cap], new_kept[:cap] = self.slot_allow, self.slot_kept
            self.slot_key, self.slot_allow, self.slot_kept = new_key, new_allow, new_kept
            self.tables = None  # repacked with the new arrays
        slot = self.filled % len(self.slot_key)
        self.filled += 1
        row = self.slot_key[slot]
        row[:] = 0
        row[:KEY_CELLS] = len(found), drop, face, everything
        row[KEY_CELLS:KEY_CELLS + len(found)] = found
        if not everything:
            self.slot_allow[slot], self.slot_kept[slot] = allow, bits

    def apply(self, state: CullState) -> None:
        if self.walker is not None:
            return self.apply_fused(state)
        camera = state.camera
        found = self.lookup(camera)
        if found is None:
            state.count(f"{self.name}.fallbacks", 1)
            return
        self.decoded = 0
        found, span = found
        drop_back = self.back_culled and self.back is not None and span <= self.back
        doors = self.shut_doors(camera, self.reach(camera), near_reach(camera))
        face = self.in_face(camera, self.reach(camera))
        keep, nodes, everything, allow, bits = self.entry(found, drop_back, doors, face)
        state.count(f"{self.name}.cells", len(found))
        if doors:
            state.count(f"{self.name}.doors_shut", len(doors))
        # what a device pays (device/costmodel.py): the view cells' boxes tested, a pattern id
        # per triangle gathered when the cells' union was not cached, each gathered triangle
        # looked up
        state.count(f"{self.name}.cells_tested", self.tested)
        state.count(f"{self.name}.ids_decoded", self.decoded)
        if everything:  # the cells see the whole world: nothing to hand on
            state.count(f"{self.name}.everything", 1)
            return
        state.nodes = nodes

        def keep_of(ids, keep=keep):
            state.count(f"{self.name}.triangles_tested", len(ids))
            return keep[ids]
        state.filters.append(keep_of)

    def apply_fused(self, state: CullState) -> None:
        """apply with vfc's walk (the Culler set walker): one compiled call finds the eye's
        cells and, when a slot holds their set (the last self.keep combinations made), walks,
        gathers and filters (pvs_frame.locate_walk_gather); else the set is made into a slot
        (fill) and the call made again. The same fallbacks, cells and triangles as apply then
        vfc."""
        camera = state.camera
        reaches = self.reaches(camera)
        if reaches is not None and self.cover is not None and self.lookup(camera) is None:
            reaches = None  # street cells: covered() needs the cells, looked up first
        if reaches is None:
            state.count("pvs.fallbacks", 1)
            self.walker.walk(state)  # vfc as usual
            return
        pad = self.tree.tol + reaches[0] + reaches[1]
        drop = self.back_culled and self.back is not None and pad <= self.back
        # in_face's reach, tested in the compiled call (-1: no face sets)
        face_reach = FACE_REACH * reaches[0] + self.tree.tol \
            if self.face_patterns is not None else -1.0
        self.decoded = 0
        found = self.frame(state, pad, face_reach, drop)
        if found is not None:  # no slot holds the set of these cells (and face sets)
            found, face = found
            if not len(found):
                state.count("pvs.fallbacks", 1)
                self.walker.walk(state)
                return
            self.fill(found, drop, face)
            self.frame(state, pad, face_reach, drop)

    def frame(self, state: CullState, pad: float, face_reach: float, drop: bool):
        """One locate_walk_gather call: None when a slot holds the set of the eye's cells (the
        frame is culled: state.nodes, state.gathered and the counters set), else (the cells
        found, the face test's answer)."""
        vfc = self.walker
        if self.slot_key is None:  # no slot yet: an empty one, which no cells match
            self.slot_key = np.zeros((1, KEY_CELLS + 4), dtype=np.int64)
            self.slot_allow = np.zeros((1, 1), dtype=bool)
            self.slot_kept = np.zeros((1, 1), dtype=np.uint64)
        if self.tables is None:  # the Culler set walker and its options after prepare
            tree = self.tree
            self.found = np.empty(len(self.cells), dtype=np.int64)  # the call's cells found
            b, g = tree._bitmap, tree.groups
            fields = (self.cells, *self.index, tree._box, tree._links, tree.read_size,
                      int(vfc.whole_below), tree._inner, tree._inner_links, bool(vfc.covering),
                      float(tree.tol), self.scratch, g.words, g.masks, g.span, b.bits,
                      b.summary, b.tops, self.ranges, self.counts, self.face_coords,
                      self.face_start, self.slot_key, self.slot_allow, self.slot_kept,
                      self.found)
            assert len(fields) == len(TABLE_FIELDS)
            self.tables = pack_tables(fields)
        x, y, z = state.camera.position
        ids = locate_walk_gather(self.tables, x, y, z, pad, face_reach, bool(drop),
                                 state.planes[None], self.gather)
        tested, runs, count, visited, tests, culled, straddling, covered, masked, slot, face, \
            cells = self.counts.tolist()
        if slot < 0:
            return self.found[:cells].copy(), bool(face)
        state.nodes = self.scratch[0, :count].copy()
        everything = bool(self.slot_key[slot, 3])
        if self.gather:
            state.gathered = (ids, runs)
        elif not everything:  # the node stage after gathers; the set's bits filter it
            state.filters.append(partial(bits_filter, state, self.slot_kept[slot].copy()))
        stats = state.stats
        stats["nodes_visited"] = stats.get("nodes_visited", 0) + visited
        stats["plane_tests"] = stats.get("plane_tests", 0) + tests
        # keys no other stage writes (vfc is absorbed; pvs runs once a frame)
        stats.update({"vfc.nodes_culled": culled, "vfc.nodes_accepted": count,
                      "pvs.cells": cells, "pvs.cells_tested": tested,
                      "pvs.ids_decoded": self.decoded})
        if vfc.whole_below >= 0:
            stats["vfc.nodes_straddling"] = straddling
        if vfc.covering:
            stats["vfc.nodes_covered"] = covered
        if everything:
            stats["pvs.everything"] = 1
        elif self.gather:  # what the staged filter tests: each gathered triangle's keep byte
            stats["pvs.triangles_tested"] = masked
        return None

    def reaches(self, camera):
        """(grow, reach): the device's reach and the near plane's, or None (fall back): no
        PVS, the device's reach beyond the bake's growth or the near plane within it, (street
        cells) a near plane their depth slack does not cover, or (portal-walk cells) an eye in
        the plane of a cell face (pvs_frame.near_plane)."""
        found = self.camera_reaches(camera)
        if found is None or self.faces is None:
            return found
        near = FACE_REACH * found[0] + self.tree.tol
        if (self.plane is None or near > self.plane) and \
                near_plane(*self.faces, np.asarray(camera.position, np.float64), near):
            return None
        return found

    def in_face(self, camera, grow: float) -> bool:
        """Whether the cells' face sets join this frame's: the eye within FACE_REACH x the
        device's reach (plus the tree's slack) of a face plane the bake walked (pvs_plane;
        reaches fell back before, when that exceeds pvs_plane). The sets hold what lines lying
        in those planes add (pvs_planes.py), which only such an eye's lines can be."""
        return self.face_patterns is not None and near_plane(
            self.face_coords, self.face_start, np.asarray(camera.position, np.float64),
            FACE_REACH * grow + self.tree.tol)

    def camera_reaches(self, camera):
        """reaches without the face test."""
        if not self.available:
            return None
        key = (camera.near, camera.fov, camera.aspect)
        x, y, z = camera.position
        m = self.magnitude
        if key == self.memo[0] and -m <= x <= m and -m <= y <= m and -m <= z <= m:
            return self.memo[1]  # the same camera shape, the device's reach the world's
        grow = self.reach(camera)
        near = camera.near
        if not self.sampled and (grow > self.grow or near <= grow / (2.0 * math.sqrt(3.0))):
            return None
        ty = math.tan(math.radians(camera.fov) / 2.0)  # near_reach, inline: every frame
        reach = near * math.sqrt(1.0 + ty * ty * (1.0 + camera.aspect ** 2))
        if self.cover is not None and (camera.near < self.cover[1] or
                                       grow + reach > self.cover[0]):
            return None  # a near plane the street cells' depth slack does not cover
        if max(abs(x), abs(y), abs(z)) <= m:
            self.memo = (key, (grow, reach))
        return grow, reach

    def lookup(self, camera):
        """(cells, span): the view cells whose sets cover this camera (grown by the device's
        reach) and how far from the eye they were looked for, or None (fall back): no PVS,
        no cell, or the device's reach beyond the bake's growth."""
        reaches = self.reaches(camera)
        if reaches is None:
            return None
        grow, reach = reaches
        found = self.eye_cells(camera, grow + reach)
        if self.cover is not None and len(found) and not self.covered(camera.eye, found,
                                                                      grow + reach):
            return None  # the near plane may leave the street cells (above, in a building)
        return (found, self.tree.tol + grow + reach) if len(found) else None

    def covered(self, eye, found, reach) -> bool:
        """The 8 corners of the box eye +- (reach + slack) each lie in one of the found cells
        (grown by the slack, and by cover[0] up and down as the bake's regions were). The
        street cells are quadtree squares at least MIN_CELL wide, and what they leave out (a
        building's inside, beyond the world, above or below the layer) are boxes larger than
        that eye box, so such a box meets it only at one of its corners: the corners inside
        mean every near-plane point is in some cell's region."""
        tol = self.tree.tol
        signs = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)]) * 2.0 - 1.0
        corners = np.asarray(eye, dtype=np.float64) + signs * (reach + tol)
        grown = np.array([tol, self.cover[0], tol])  # the bake covered cover[0] above, below
        boxes = self.cells[found]
        inside = ((boxes[None, :, 0] - grown <= corners[:, None])
                  & (corners[:, None] <= boxes[None, :, 1] + grown)).all(axis=2)
        return bool(inside.any(axis=1).all())


def bits_filter(state, kept, ids) -> np.ndarray:
    """(n,) bool: which of ids (n,) int64 the set's bits kept (T // 64 + 1,) uint64 hold
    (pvs_frame.keep_bits' layout); counts them in pvs.triangles_tested."""
    state.count("pvs.triangles_tested", len(ids))
    return ((kept[ids >> 6] >> (ids & 63).astype(np.uint64)) & np.uint64(1)).astype(bool)


def packed_planes(faces) -> tuple:
    """(coords (F,) float64, start (4,) int64) of three sorted (F_a,) arrays of view cells'
    face coordinates, one per axis, laid end to end: axis a's at coords[start[a]:start[a + 1]]
    (pvs_frame.near_plane's layout)."""
    coords = np.concatenate([np.asarray(f, dtype=np.float64) for f in faces])
    return coords, np.concatenate([[0], np.cumsum([len(f) for f in faces])]).astype(np.int64)


def near_reach(camera) -> float:
    """Distance from the eye to the near plane's corners."""
    ty = math.tan(math.radians(camera.fov) / 2.0)
    return camera.near * math.sqrt(1.0 + ty * ty * (1.0 + camera.aspect ** 2))


def set_nodes(tree: Tree, keep) -> tuple:
    """(cover (D,) int64, some (N,) bool): the topmost nodes whose every non-empty leaf
    references a kept triangle and that hold at least one, and the nodes whose subtree holds
    one; computed level by level from the leaves up.

    keep : (T,) bool the kept triangles
    """
    n = tree.node_count
    refs = np.asarray(tree.tri_refs, dtype=np.int64)
    count, first = tree.child_count, tree.first_child
    leaf = count == 0
    hits = np.zeros(n, dtype=np.int64)
    if len(refs):
        csum = np.concatenate([[0], np.cumsum(keep[refs])])
        hits[leaf] = csum[tree.ref_end[leaf]] - csum[tree.ref_start[leaf]]
    full = leaf & ((hits > 0) | (tree.ref_end == tree.ref_start))
    some = hits > 0
    level_start = np.asarray(tree.partition.level_start, dtype=np.int64)
    for level in range(len(level_start) - 2, -1, -1):
        nodes = np.arange(level_start[level], level_start[level + 1])
        inner = nodes[count[nodes] > 0]
        if not len(inner):
            continue
        lo, hi = first[inner], first[inner] + count[inner]
        c_full = np.concatenate([[0], np.cumsum(full)])
        c_some = np.concatenate([[0], np.cumsum(some)])
        full[inner] = c_full[hi] - c_full[lo] == count[inner]
        some[inner] = c_some[hi] - c_some[lo] > 0
    full &= some
    inner = np.flatnonzero(count > 0)
    kids, _ = tree.children(inner)
    parent_full = np.zeros(n, dtype=bool)
    parent_full[kids] = np.repeat(full[inner], count[inner])
    return np.flatnonzero(full & ~parent_full).astype(np.int64), some
