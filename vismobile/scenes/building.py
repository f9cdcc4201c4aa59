"""World 1: a two-storey building of 40 axis-aligned rooms with doorways, arches, windows and a ramp.

Thesis §5.2: "2 floors, 40 rooms aligned with the axes, 6,199 triangles spread uniformly".
Walls have thickness, so a wall between two rooms is two opposite faces; every wall, floor and
ceiling face points into the room it bounds (single-sided: backface culling removes the other
rooms' backs). Units are metres, y is up. The plan (rooms, doors, windows, stair) is data the
trajectory generator reads, so paths go through doorway centres.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .surfaces import MeshCollector, fan_split, holed_rect, merge, quad, tiled_rect

X_EDGES = (0.0, 8.0, 14.0, 24.0, 31.0, 40.0)  # wall lines along x: 5 room columns
Z_EDGES = (0.0, 8.0, 17.0, 24.0, 32.0)  # wall lines along z: 4 room rows
WALL = 0.2  # wall and slab thickness
FLOOR_Y = (0.0, 3.2)  # floor height per storey
ROOM_HEIGHT = 3.0  # floor to ceiling
DOOR = (1.0, 2.1)  # width, height
ARCH = (2.4, 2.6)
WINDOW = (1.4, 0.9, 2.2)  # width, sill height, top height
TILE = 2.2  # largest quad side on walls, floors and ceilings (sets the triangle budget)
SEED = 20080501
STAIR_ROOM = (3, 0)  # ground-floor room holding the ramp; the room above has the opening
RAMP = dict(z0=0.1, z1=1.6, x_foot=24.6, x_top=30.0, landing=30.9, hole_x0=26.2)

# (storey, room a, room b, kind, centre along the wall or None for a seeded one)
DOORS = (
    (0, (0, 1), (1, 1), "arch", 12.5), (0, (1, 1), (2, 1), "arch", 12.5),
    (0, (2, 1), (3, 1), "arch", 12.5), (0, (3, 1), (4, 1), "arch", 12.5),
    (0, (0, 1), (0, 2), "arch", 5.0),
    (0, (0, 0), (0, 1), "door", None), (0, (0, 0), (1, 0), "door", None),
    (0, (2, 0), (2, 1), "door", 19.0), (0, (3, 0), (3, 1), "door", 28.5),
    (0, (4, 0), (4, 1), "door", None), (0, (1, 1), (1, 2), "door", None),
    (0, (3, 1), (3, 2), "door", None), (0, (0, 2), (1, 2), "door", 22.9),
    (0, (2, 2), (3, 2), "door", None), (0, (3, 2), (4, 2), "door", None),
    (0, (0, 2), (0, 3), "door", None), (0, (2, 2), (2, 3), "door", None),
    (0, (4, 2), (4, 3), "door", None), (0, (1, 3), (2, 3), "door", None),
    (0, (3, 3), (4, 3), "door", None),
    (1, (3, 0), (3, 1), "door", 29.0), (1, (3, 0), (4, 0), "door", None),
    (1, (2, 0), (3, 0), "door", None), (1, (1, 0), (2, 0), "door", None),
    (1, (0, 0), (1, 0), "door", None), (1, (0, 0), (0, 1), "door", None),
    (1, (1, 0), (1, 1), "door", None), (1, (4, 0), (4, 1), "door", None),
    (1, (3, 1), (2, 1), "door", 13.5), (1, (2, 1), (2, 2), "door", 18.0),
    (1, (0, 1), (0, 2), "door", None), (1, (3, 1), (3, 2), "door", None),
    (1, (3, 2), (4, 2), "door", None), (1, (4, 2), (4, 3), "door", None),
    (1, (1, 2), (2, 2), "door", None), (1, (1, 2), (1, 3), "door", None),
    (1, (0, 3), (1, 3), "door", None), (1, (2, 3), (3, 3), "door", None),
    (1, (3, 2), (3, 3), "door", None),
)


@dataclass(frozen=True)
class Door:
    """An opening through an interior wall: the wall plane is axis = plane, width along the wall."""

    storey: int
    rooms: tuple  # ((c, r), (c, r))
    axis: int  # 0: wall plane x = plane, 2: wall plane z = plane
    plane: float
    centre: float  # along the wall (z for axis 0, x for axis 2)
    width: float
    height: float

    def point(self, eye: float = 1.7) -> np.ndarray:
        """(3,) float64 middle of the opening at eye height above its storey's floor."""
        p = np.zeros(3)
        p[self.axis], p[2 - self.axis], p[1] = self.plane, self.centre, FLOOR_Y[self.storey] + eye
        return p


@dataclass
class Plan:
    """The building's layout: room boxes, doors, windows (outer-wall openings) and the ramp."""

    rooms: dict = field(default_factory=dict)  # (storey, c, r) -> (2, 3) interior box
    doors: list = field(default_factory=list)
    windows: list = field(default_factory=list)  # (storey, axis, plane, centre, side room)
    entrances: list = field(default_factory=list)  # door-sized outer-wall openings, as windows

    def door(self, storey: int, a, b) -> Door:
        for door in self.doors:
            if door.storey == storey and set(door.rooms) == {tuple(a), tuple(b)}:
                return door
        raise KeyError(f"no door between {a} and {b} on storey {storey}")

    def floor_height(self, x, z) -> np.ndarray:
        """Height of the walkable surface under (x, z): the ramp in the stair room, else 0.

        Only storey 0 has a ramp; callers on storey 1 use FLOOR_Y[1] directly.
        """
        x, z = np.asarray(x, float), np.asarray(z, float)
        on_ramp = (z >= RAMP["z0"]) & (z <= RAMP["z1"]) & (x >= RAMP["x_foot"])
        rise = np.clip((x - RAMP["x_foot"]) / (RAMP["x_top"] - RAMP["x_foot"]), 0.0, 1.0)
        return np.where(on_ramp, rise * FLOOR_Y[1], 0.0)


def room_box(storey: int, c: int, r: int) -> np.ndarray:
    """(2, 3) float64 interior of room (c, r) on a storey: wall lines inset by half a wall."""
    y = FLOOR_Y[storey]
    return np.array([[X_EDGES[c] + WALL / 2, y, Z_EDGES[r] + WALL / 2],
                     [X_EDGES[c + 1] - WALL / 2, y + ROOM_HEIGHT, Z_EDGES[r + 1] - WALL / 2]])


def make_plan(seed: int = SEED) -> Plan:
    """The deterministic floor plan: seeded door offsets where DOORS leaves them open."""
    rng = np.random.default_rng(seed)
    plan = Plan()
    for storey in (0, 1):
        for c in range(len(X_EDGES) - 1):
            for r in range(len(Z_EDGES) - 1):
                plan.rooms[(storey, c, r)] = room_box(storey, c, r)
    for storey, a, b, kind, centre in DOORS:
        (ca, ra), (cb, rb) = sorted([a, b])
        if abs(ca - cb) + abs(ra - rb) != 1:
            raise ValueError(f"rooms {a} and {b} are not neighbours")
        width, height = ARCH if kind == "arch" else DOOR
        axis = 0 if ca != cb else 2
        plane = X_EDGES[cb] if axis == 0 else Z_EDGES[rb]
        lo, hi = (Z_EDGES[ra], Z_EDGES[ra + 1]) if axis == 0 else (X_EDGES[ca], X_EDGES[ca + 1])
        offset = rng.uniform(lo + 1.2, hi - 1.2)  # drawn always, so fixed centres keep the stream
        plan.doors.append(Door(storey, ((ca, ra), (cb, rb)), axis, plane,
                               offset if centre is None else centre, width, height))
    for storey in (0, 1):
        for c in range(len(X_EDGES) - 1):
            for r in range(len(Z_EDGES) - 1):
                sides = []
                if r == 0:
                    sides.append((2, Z_EDGES[0]))
                if r == len(Z_EDGES) - 2:
                    sides.append((2, Z_EDGES[-1]))
                if c == 0:
                    sides.append((0, X_EDGES[0]))
                if c == len(X_EDGES) - 2:
                    sides.append((0, X_EDGES[-1]))
                for axis, plane in sides:
                    lo, hi = (Z_EDGES[r], Z_EDGES[r + 1]) if axis == 0 else (X_EDGES[c], X_EDGES[c + 1])
                    centre = (lo + hi) / 2 + rng.uniform(-1.5, 1.5)
                    if storey == 0 and (c, r) == STAIR_ROOM:
                        continue  # the ramp runs along this outer wall
                    plan.windows.append((storey, axis, plane, centre, (c, r)))
    return plan


def _room_openings(plan: Plan, storey: int, c: int, r: int) -> dict:
    """Holes per wall side of a room: {(axis, plane): [(centre, width, bottom, top), ...]}."""
    openings = {}
    for door in plan.doors:
        if door.storey == storey and (c, r) in door.rooms:
            openings.setdefault((door.axis, door.plane), []).append(
                (door.centre, door.width, 0.0, door.height))
    for w_storey, axis, plane, centre, room in plan.windows:
        if w_storey == storey and room == (c, r):
            openings.setdefault((axis, plane), []).append(
                (centre, WINDOW[0], WINDOW[1], WINDOW[2]))
    for e_storey, axis, plane, centre, room in plan.entrances:
        if e_storey == storey and room == (c, r):
            openings.setdefault((axis, plane), []).append((centre, DOOR[0], 0.0, DOOR[1]))
    return openings


def _opening_reveal(storey, axis, plane, centre, width, bottom, top):
    """The faces lining an opening through a wall: two sides, a lintel and, if raised, a sill."""
    fy = FLOOR_Y[storey]
    a = 2 - axis  # along-wall axis
    lo, hi = plane - WALL / 2, plane + WALL / 2
    parts = []

    def point(across, along, y):
        p = np.zeros(3)
        p[axis], p[a], p[1] = across, along, y
        return p

    for along, sign in ((centre - width / 2, 1.0), (centre + width / 2, -1.0)):
        facing = np.zeros(3)
        facing[a] = sign
        parts.append(quad([point(lo, along, fy + bottom), point(hi, along, fy + bottom),
                           point(hi, along, fy + top), point(lo, along, fy + top)], facing))
    for y, facing_y in ((fy + top, -1.0), (fy + bottom, 1.0)):
        parts.append(quad([point(lo, centre - width / 2, y), point(hi, centre - width / 2, y),
                           point(hi, centre + width / 2, y), point(lo, centre + width / 2, y)],
                          (0.0, facing_y, 0.0)))
    return merge(parts)


def _stair_parts() -> dict:
    """The ramp, its landing and the faces lining the slab opening above it, by object name."""
    z0, z1 = RAMP["z0"], RAMP["z1"]
    xf, xt, xl, hx = RAMP["x_foot"], RAMP["x_top"], RAMP["landing"], RAMP["hole_x0"]
    top = FLOOR_Y[1]
    slope = tiled_rect((xf, 0.0, z0), (xt - xf, top, 0.0), (0.0, 0.0, z1 - z0), 6, 1,
                       (-top, xt - xf, 0.0))
    side = (np.array([[xf, 0.0, z1], [xt, 0.0, z1], [xt, top, z1]]), np.array([[0, 1, 2]], np.int32))
    landing = quad([(xt, top, z0), (xl, top, z0), (xl, top, z1), (xt, top, z1)], (0, 1, 0))
    landing_side = quad([(xt, 0, z1), (xl, 0, z1), (xl, top, z1), (xt, top, z1)], (0, 0, 1))
    y0, y1 = ROOM_HEIGHT, FLOOR_Y[1]
    well = merge([
        quad([(hx, y0, z0), (hx, y0, z1), (hx, y1, z1), (hx, y1, z0)], (1, 0, 0)),
        quad([(xl, y0, z0), (xl, y0, z1), (xl, y1, z1), (xl, y1, z0)], (-1, 0, 0)),
        quad([(hx, y0, z0), (xl, y0, z0), (xl, y1, z0), (hx, y1, z0)], (0, 0, 1)),
        quad([(hx, y0, z1), (xl, y0, z1), (xl, y1, z1), (hx, y1, z1)], (0, 0, -1)),
    ])
    return {"ramp": merge([slope, side, landing, landing_side]), "stairwell": well}


def _stair_hole(box) -> tuple:
    """The slab opening in the stair room's local floor frame: (u0, u1, v0, v1)."""
    return (RAMP["hole_x0"] - box[0, 0], RAMP["landing"] - box[0, 0],
            RAMP["z0"] - box[0, 2], RAMP["z1"] - box[0, 2])


def build_building(target: int | None = 6199, plan: Plan | None = None, tile: float = TILE):
    """World 1 as (World, Plan); with a target, ceiling quads are fan-split to hit it exactly.

    Fan-splitting adds 2 triangles per quad without changing the surface, and a split of the
    ramp's side triangle fixes the parity. Raises ValueError if the target is below the base
    count or above what the ceilings can absorb.
    """
    plan = plan or make_plan()
    mesh = MeshCollector()
    ceilings = []
    for (storey, c, r), box in plan.rooms.items():
        lo, hi = box
        size = hi - lo
        tag = f"s{storey}_r{c}{r}"
        stair_below = storey == 0 and (c, r) == STAIR_ROOM
        stair_above = storey == 1 and (c, r) == STAIR_ROOM
        floor_holes = [_stair_hole(box)] if stair_above else []
        mesh.add(f"{tag}_floor", *holed_rect(lo, (1, 0, 0), (0, 0, 1), size[0], size[2],
                                             floor_holes, tile, (0, 1, 0)))
        ceiling_origin = (lo[0], hi[1], lo[2])
        if stair_below:
            mesh.add(f"{tag}_ceiling", *holed_rect(ceiling_origin, (1, 0, 0), (0, 0, 1), size[0],
                                                   size[2], [_stair_hole(box)], tile, (0, -1, 0)))
        else:
            nu, nv = int(np.ceil(size[0] / tile)), int(np.ceil(size[2] / tile))
            ceilings.append((f"{tag}_ceiling", tiled_rect(ceiling_origin, (size[0], 0, 0),
                                                          (0, 0, size[2]), nu, nv, (0, -1, 0))))
        openings = _room_openings(plan, storey, c, r)
        walls = []
        for axis in (0, 2):
            a = 2 - axis
            for side, plane_line in ((0, (X_EDGES if axis == 0 else Z_EDGES)[(c, r)[axis // 2]]),
                                     (1, (X_EDGES if axis == 0 else Z_EDGES)[(c, r)[axis // 2] + 1])):
                face = lo[axis] if side == 0 else hi[axis]
                facing = np.zeros(3)
                facing[axis] = 1.0 if side == 0 else -1.0
                origin = lo.copy()
                origin[axis] = face
                along = np.zeros(3)
                along[a] = 1.0
                holes = [(centre - width / 2 - lo[a], centre + width / 2 - lo[a], bottom, top)
                         for centre, width, bottom, top in openings.get((axis, plane_line), [])]
                walls.append(holed_rect(origin, along, (0, 1, 0), size[a], ROOM_HEIGHT,
                                        holes, tile, facing))
        for w_storey, axis, plane, centre, room in plan.windows:
            if w_storey == storey and room == (c, r):
                walls.append(_opening_reveal(storey, axis, plane, centre, *WINDOW))
        for e_storey, axis, plane, centre, room in plan.entrances:
            if e_storey == storey and room == (c, r):
                walls.append(_opening_reveal(storey, axis, plane, centre, DOOR[0], 0.0, DOOR[1]))
        mesh.add(f"{tag}_wall", *merge(walls))
    for door in plan.doors:
        (ca, ra), (cb, rb) = door.rooms
        mesh.add(f"s{door.storey}_door_{ca}{ra}_{cb}{rb}",
                 *_opening_reveal(door.storey, door.axis, door.plane, door.centre, door.width,
                                  0.0, door.height))
    stairs = _stair_parts()
    base = mesh.triangle_count + sum(len(p[1]) for _, p in ceilings) + sum(
        len(p[1]) for p in stairs.values())
    extra = 0 if target is None else target - base
    capacity = sum(len(p[1]) // 2 for _, p in ceilings)
    if extra < 0 or extra // 2 > capacity:
        raise ValueError(f"building has {base} triangles; cannot pad to {target}")
    if extra % 2:  # split the ramp's side triangle in two at its hypotenuse midpoint
        v, t = stairs["ramp"]
        side = t[6 * 2]  # slope 12 triangles, then the side triangle
        mid = (v[side[0]] + v[side[2]]) / 2
        v = np.vstack([v, mid])
        new = np.array([[side[0], side[1], len(v) - 1], [side[1], side[2], len(v) - 1]])
        stairs["ramp"] = (v, np.vstack([np.delete(t, 12, axis=0), new]).astype(np.int32))
    quads_left = extra // 2
    for index, (name, (v, t)) in enumerate(ceilings):
        share = quads_left // (len(ceilings) - index)  # spread evenly, earlier rooms get fewer
        share = min(share, len(t) // 2)
        mesh.add(name, *fan_split(v, t, share))
        quads_left -= share
    for name, part in stairs.items():
        mesh.add(name, *part)
    return mesh.world("w1"), plan
