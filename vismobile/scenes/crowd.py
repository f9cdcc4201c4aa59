"""W7's moving things (issue 25): people walking loops in the building's rooms, cars driving rings
on the city's streets, and the doors' hinge tracks, as a JSON motion document
(files/motionfile.py's format) keyed by object name.

Every mover stands in the world at its pose at t = 0 (its rest pose); its track says how far it
moved from there (translation) and how it turned about its pivot, the rest position (rotation
about +y). People and cars loop (one circuit per track); doors turn about their hinges on a
schedule tied to W7's path: the entrance and the door into room (2, 0) open a second before
the walker reaches them and close a second after, a few doors swing on their own, and every
other door stays shut. Deterministic: SEED.
"""
from __future__ import annotations

import numpy as np

from ..geometry.boxes import box_mesh
from . import building

SEED = 20261127
FPS = 30.0
DURATION = 40.0  # seconds: W7's path is 1,200 frames at 30 fps
PERSON = np.array([[[-0.18, 0.0, -0.10], [0.18, 0.79, 0.10]],  # legs, torso, head; faces +z
                   [[-0.23, 0.80, -0.13], [0.23, 1.45, 0.13]],
                   [[-0.11, 1.50, -0.11], [0.11, 1.72, 0.11]]])
CAR = np.array([[[-0.9, 0.3, -2.1], [0.9, 1.2, 2.1]],  # body and cabin; faces +z
                [[-0.8, 1.21, -1.2], [0.8, 1.76, 0.8]]])
WALK = 1.2  # m/s
DRIVE = 8.0  # m/s
ROOM_INSET = 1.5  # a person's loop keeps this far from the room's walls (doors swing 1.04 m)
PEOPLE = 20
# (x0, z0, x1, z1, clockwise, cars): rings round block (1, 1) in the inner and outer lanes of
# its streets, and one round the whole city on the ground beyond the outer blocks
RINGS = ((74.0, 74.0, 146.0, 146.0, False, 5), (66.0, 66.0, 154.0, 154.0, True, 4),
         (-20.0, -20.0, 240.0, 240.0, False, 3))
SWING = 1.0  # seconds to open or close a door
SWINGING = 6  # doors that open and shut on their own, every SWING_PERIOD seconds
SWING_PERIOD = 10.0
# W7's path (tools/make_trajectories.py hybrid()) crosses these doors at these frames
PATH_DOORS = {"door_entrance": ((459, 460), (887, 888)), "door_s0_20_21": ((617, 728),)}
PATH_ROOMS = {(0, 0, 1), (0, 1, 1), (0, 2, 1), (0, 2, 0)}  # rooms the path walks through


def yaw_quaternion(degrees) -> np.ndarray:
    """(K, 4) float64 quaternions x, y, z, w turning by `degrees` (K,) about +y."""
    half = np.radians(np.asarray(degrees, dtype=np.float64).reshape(-1)) / 2
    out = np.zeros((len(half), 4))
    out[:, 1], out[:, 3] = np.sin(half), np.cos(half)
    return out


def heading(d) -> float:
    """Degrees about +y that turn +z toward the (x, z) direction d."""
    return float(np.degrees(np.arctan2(d[0], d[1])))


def outward_boxes(boxes) -> tuple:
    """(vertices (8B, 3), triangles (12B, 3)) of (B, 2, 3) boxes wound outward (positive
    signed volume: geometry.boxes.box_mesh's winding is checked, not assumed)."""
    vertices, triangles = box_mesh(boxes)
    corners = vertices[triangles]
    volume = np.einsum("ij,ij->", corners[:, 0], np.cross(corners[:, 1], corners[:, 2]))
    return vertices, (triangles if volume > 0 else triangles[:, ::-1]).astype(np.int32)


def mesh_at(boxes, position, yaw: float) -> tuple:
    """(vertices, triangles) of local boxes (facing +z) turned by yaw about +y, stood at position."""
    vertices, triangles = outward_boxes(boxes)
    a = np.radians(yaw)
    turn = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    return vertices @ turn.T + np.asarray(position, float), triangles


def ring_keys(corners, speed: float, corner_cut: float) -> tuple:
    """One circuit of a closed polygon (K, 2) x, z at `speed`, cutting each corner over
    `corner_cut` metres on both sides: (times (N,), positions (N, 2), yaws (N,) unwrapped
    degrees), ending where it starts (a looping track)."""
    corners = np.asarray(corners, dtype=np.float64)
    points, yaws = [], []
    count = len(corners)
    for k in range(count):
        a, b, c = corners[k - 1], corners[k], corners[(k + 1) % count]
        into, out = (b - a) / np.linalg.norm(b - a), (c - b) / np.linalg.norm(c - b)
        points += [b - corner_cut * into, b + corner_cut * out]
        yaws += [heading(into), heading(out)]
    points.append(points[0])
    yaws = np.degrees(np.unwrap(np.radians(yaws + [yaws[0]])))
    points = np.array(points)
    times = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return times / speed, points, yaws


def shifted(times, xz, yaws, phase: float) -> tuple:
    """The circuit (ring_keys) started `phase` seconds later: (times, xz, yaws) keys from 0 to
    the period, sampled from the original circuit at (t + phase) mod period."""
    period = float(times[-1])
    shift = phase % period
    t = np.unique(np.concatenate([[0.0, period], (times - shift) % period]))
    source = (t + shift) % period
    source[-1] = shift  # the last key is the first pose again, a whole circuit on
    xz_t = np.column_stack([np.interp(source, times, xz[:, j]) for j in range(2)])
    yaw_t = np.interp(source, times, yaws)
    yaw_t[-1] = yaw_t[0] + (yaws[-1] - yaws[0])
    yaw_t[:-1] = np.degrees(np.unwrap(np.radians(yaw_t[:-1])))
    return t, xz_t, yaw_t


def loop_entry(times, xz, yaws, y: float) -> tuple:
    """(rest position (3,), rest yaw, motion entry dict) of a looping mover whose rest pose is
    its first key: translation from there, rotation about it."""
    rest = np.array([xz[0, 0], y, xz[0, 1]])
    moved = np.column_stack([xz[:, 0] - xz[0, 0], np.zeros(len(xz)), xz[:, 1] - xz[0, 1]])
    entry = {"times": _round(times), "translation": _round(moved),
             "rotation": _round(yaw_quaternion(yaws - yaws[0])), "interpolation": "linear",
             "loop": True, "pivot": _round(rest)}
    return rest, float(yaws[0]), entry


def _round(values) -> list:
    """JSON-ready nested lists, 9 decimals (the file stays small and byte-stable)."""
    return np.round(np.asarray(values, dtype=np.float64), 9).tolist()


def people(plan, offset) -> list:
    """[(name, vertices, triangles, motion entry)]: PEOPLE people, each walking a loop
    ROOM_INSET inside a seeded room off W7's path (the stair room left out) of the building
    standing at `offset` (3,)."""
    rng = np.random.default_rng(SEED)
    stair = building.STAIR_ROOM
    rooms = sorted(k for k in plan.rooms if k not in PATH_ROOMS and k[1:] != stair)
    out = []
    for n, index in enumerate(sorted(rng.choice(len(rooms), PEOPLE, replace=False))):
        lo, hi = plan.rooms[rooms[index]] + np.asarray(offset, dtype=np.float64)
        x0, x1, z0, z1 = lo[0] + ROOM_INSET, hi[0] - ROOM_INSET, lo[2] + ROOM_INSET, hi[2] - ROOM_INSET
        ring = [(x0, z0), (x1, z0), (x1, z1), (x0, z1)]
        if rng.random() < 0.5:
            ring = ring[::-1]
        times, xz, yaws = ring_keys(ring, WALK, 0.3)
        times, xz, yaws = shifted(times, xz, yaws, rng.uniform(0.0, times[-1]))
        rest, yaw, entry = loop_entry(times, xz, yaws, lo[1])
        out.append((f"person_{n:02d}", *mesh_at(PERSON, rest, yaw), entry))
    return out


def cars() -> list:
    """[(name, vertices, triangles, motion entry)]: the RINGS' cars, evenly spaced on each."""
    out = []
    for x0, z0, x1, z1, clockwise, count in RINGS:
        ring = [(x0, z0), (x1, z0), (x1, z1), (x0, z1)]
        if clockwise:
            ring = ring[::-1]
        times, xz, yaws = ring_keys(ring, DRIVE, 4.0)
        for k in range(count):
            t, p, y = shifted(times, xz, yaws, times[-1] * k / count)
            rest, yaw, entry = loop_entry(t, p, y, 0.0)
            out.append((f"car_{len(out):02d}", *mesh_at(CAR, rest, yaw), entry))
    return out


def swing_keys(open_degrees: float, intervals) -> tuple:
    """(times, yaw degrees) of a door shut at 0, opening over SWING from each interval's start
    and shutting over SWING from its end, in 15-degree keys (the hinge stays put between keys:
    the motion turns about it). Shut keys are exactly 0."""
    steps = np.linspace(0.0, 1.0, int(abs(open_degrees) // 15) + 1)
    times, yaws = [0.0], [0.0]
    for start, end in intervals:
        times += list(start + SWING * steps) + list(end + SWING * steps)
        yaws += list(open_degrees * steps) + list(open_degrees * steps[::-1])
    return np.array(times), np.array(yaws)


def door_entries(leaves, mode: str = "scheduled") -> dict:
    """{door name: motion entry}: 'scheduled' (the path's doors open as the walker passes,
    SWINGING seeded others open and shut every SWING_PERIOD seconds, the rest stay shut),
    'open' (every door open all the time) or 'closed' (every door shut all the time)."""
    if mode not in ("scheduled", "open", "closed"):
        raise ValueError(f"unknown door mode {mode!r}: scheduled, open or closed")
    rng = np.random.default_rng([SEED, 1])
    others = [leaf.name for leaf in leaves if leaf.name not in PATH_DOORS]
    swinging = set(np.array(others)[rng.choice(len(others), SWINGING, replace=False)])
    entries = {}
    for leaf in leaves:
        entry = {"pivot": _round(leaf.hinge), "interpolation": "linear"}
        if mode == "open" or (mode == "scheduled" and leaf.name in PATH_DOORS):
            if mode == "open":
                times, yaws = np.array([0.0]), np.array([leaf.open_degrees])
            else:
                times, yaws = swing_keys(leaf.open_degrees, [
                    (a / FPS - SWING - 1.0, b / FPS + 1.0) for a, b in PATH_DOORS[leaf.name]])
        elif mode == "scheduled" and leaf.name in swinging:
            phase = rng.uniform(0.5, SWING_PERIOD - 2 * SWING - 4.0)
            times, yaws = swing_keys(leaf.open_degrees, [(phase, phase + SWING + 3.0)])
            times, yaws = np.append(times, SWING_PERIOD), np.append(yaws, 0.0)
            entry["loop"] = True
        else:
            times, yaws = np.array([0.0]), np.array([0.0])
        entry.update(times=_round(times), rotation=_round(yaw_quaternion(yaws)))
        entries[leaf.name] = entry
    return entries


def motion_document(leaves, people_parts, car_parts, doors: str = "scheduled") -> dict:
    """W7's JSON motion document (files/motionfile.py): doors, people and cars."""
    objects = door_entries(leaves, doors)
    for name, _, _, entry in list(people_parts) + list(car_parts):
        objects[name] = entry
    return {"fps": FPS, "objects": objects}


def street_walkers(count: int, seed: int = SEED) -> list:
    """[(name, vertices, triangles, motion entry)]: `count` people walking loops round the
    city's blocks on the pavement (1.5-4 m off the blocks' edges), each from its own place on
    its loop: many moving objects for the viewer's benchmark (tools/bench_w7.py)."""
    from . import city

    rng = np.random.default_rng([seed, 2])
    out = []
    span = city.LOTS * city.LOT
    for n in range(count):
        bx, bz = rng.integers(0, city.BLOCKS, 2)
        gap = rng.uniform(1.5, 4.0)
        x0, z0 = city.block_origin(bx) - gap, city.block_origin(bz) - gap
        ring = [(x0, z0), (x0 + span + 2 * gap, z0), (x0 + span + 2 * gap, z0 + span + 2 * gap),
                (x0, z0 + span + 2 * gap)]
        if rng.random() < 0.5:
            ring = ring[::-1]
        times, xz, yaws = ring_keys(ring, WALK, 0.3)
        times, xz, yaws = shifted(times, xz, yaws, rng.uniform(0.0, times[-1]))
        rest, yaw, entry = loop_entry(times, xz, yaws, 0.0)
        out.append((f"walker_{n:04d}", *mesh_at(PERSON, rest, yaw), entry))
    return out
