"""World 7 (ours, issue 25): the W1 building standing in the W5 city, with doors in its doorways.

The building (building.py, 6,199-triangle plan without the padding) stands with its corner at
OFFSET, in the corner of city block (1, 1), so its west wall faces the street x = 70 that the
thesis's outdoor path walks; the city's buildings whose lots it covers are left out. W1's walls
face only into their rooms, so W7 adds the outside: each outer wall's outer face (holes for the
windows and the entrance) and a roof. The ground keeps a hole under the building, so no floor
lies in the ground's plane. The entrance replaces the west window of room (0, 1), the gallery.

Doors (`door_*` objects, DOOR_PREFIX) fill every door-sized doorway and the entrance. A door is
a closed outward box that contains its doorway's tunnel (the opening grown by DOOR_LAP along
the wall and up, sunk DOOR_LAP into the floor slab, 2 * DOOR_LAP thicker than the wall), so
in its rest pose - closed - every sight line through the doorway meets its surface. It turns
about a vertical hinge at one edge of its room-b face (Leaf.hinge, opening into room b by
Leaf.open_degrees). Units are metres, y is up.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..world.world import World
from . import building, city, crowd
from .building import DOOR, FLOOR_Y, ROOM_HEIGHT, WALL, WINDOW, X_EDGES, Z_EDGES
from .surfaces import MeshCollector, holed_rect, quad

OFFSET = np.array([city.block_origin(1), 0.0, city.block_origin(1)])  # building corner (80, 0, 80)
ENTRANCE_ROOM = (0, 1)  # ground floor, west side: the gallery's west end
ENTRANCE_CENTRE = 12.5  # z along the west wall, on the gallery's axis
LOT_CLEARANCE = 3.0  # city buildings within this of the building's footprint are left out
DOOR_LAP = 0.01  # a door reaches this far past its opening on every side (and into the floor)
DOOR_PREFIX = "door_"
TOP = FLOOR_Y[1] + ROOM_HEIGHT + WALL  # roof height: upper ceiling plus a slab
GROUND_TILE = 16.6


@dataclass(frozen=True)
class Leaf:
    """One door: its object name, closed box (2, 3) in world coordinates, hinge point (3,)
    (the vertical axis it turns about) and the angle about +y that opens it, in degrees."""

    name: str
    box: np.ndarray
    hinge: np.ndarray
    open_degrees: float


def make_plan() -> building.Plan:
    """W1's plan with the west window of the entrance room turned into a door-sized entrance."""
    plan = building.make_plan()
    west = [w for w in plan.windows
            if w[0] == 0 and w[1] == 0 and w[2] == X_EDGES[0] and w[4] == ENTRANCE_ROOM]
    plan.windows.remove(west[0])
    plan.entrances.append((0, 0, X_EDGES[0], ENTRANCE_CENTRE, ENTRANCE_ROOM))
    return plan


def footprint() -> np.ndarray:
    """(2, 2) float64 [[x0, z0], [x1, z1]] of the building's outer faces in world coordinates."""
    lo = np.array([X_EDGES[0], Z_EDGES[0]]) - WALL / 2
    hi = np.array([X_EDGES[-1], Z_EDGES[-1]]) + WALL / 2
    return np.stack([lo, hi]) + OFFSET[[0, 2]]


def leaves(plan: building.Plan) -> list:
    """A Leaf per door-sized doorway (arches stay open) and for the entrance, plan order.

    The box spans the wall (plane +- (WALL/2 + DOOR_LAP)), the opening grown by DOOR_LAP along
    the wall and at the top, and DOOR_LAP below the floor; the hinge stands at the box's
    low-along corner on room b's side (the high side of the wall), so the door opens into b.
    """
    openings = [(f"{DOOR_PREFIX}s{d.storey}_{d.rooms[0][0]}{d.rooms[0][1]}_"
                 f"{d.rooms[1][0]}{d.rooms[1][1]}", d.storey, d.axis, d.plane, d.centre)
                for d in plan.doors if (d.width, d.height) == DOOR]
    openings += [(f"{DOOR_PREFIX}entrance", storey, axis, plane, centre)
                 for storey, axis, plane, centre, _ in plan.entrances]
    result = []
    for name, storey, axis, plane, centre in openings:
        along = 2 - axis
        lo, hi = np.zeros(3), np.zeros(3)
        lo[axis], hi[axis] = plane - WALL / 2 - DOOR_LAP, plane + WALL / 2 + DOOR_LAP
        lo[along], hi[along] = centre - DOOR[0] / 2 - DOOR_LAP, centre + DOOR[0] / 2 + DOOR_LAP
        lo[1], hi[1] = FLOOR_Y[storey] - DOOR_LAP, FLOOR_Y[storey] + DOOR[1] + DOOR_LAP
        box = np.stack([lo, hi]) + OFFSET
        hinge = box[0].copy()
        hinge[axis] = box[1, axis]
        # +90 about y turns +z toward +x (axis 0); -90 turns +x toward +z (axis 2)
        result.append(Leaf(name, box, hinge, 90.0 if axis == 0 else -90.0))
    return result


def _outer_walls(plan: building.Plan) -> list:
    """(name, (vertices, triangles)) of the four outer faces with their openings, and the roof."""
    x0, x1 = X_EDGES[0] - WALL / 2, X_EDGES[-1] + WALL / 2
    z0, z1 = Z_EDGES[0] - WALL / 2, Z_EDGES[-1] + WALL / 2
    sides = {  # (axis, wall line): (origin, along direction, length, outward facing)
        (0, X_EDGES[0]): ((x0, 0.0, z0), (0, 0, 1), z1 - z0, (-1, 0, 0)),
        (0, X_EDGES[-1]): ((x1, 0.0, z0), (0, 0, 1), z1 - z0, (1, 0, 0)),
        (2, Z_EDGES[0]): ((x0, 0.0, z0), (1, 0, 0), x1 - x0, (0, 0, -1)),
        (2, Z_EDGES[-1]): ((x0, 0.0, z1), (1, 0, 0), x1 - x0, (0, 0, 1)),
    }
    parts = []
    for (axis, line), (origin, along, length, facing) in sides.items():
        start = origin[2 - axis]
        holes = [(centre - WINDOW[0] / 2 - start, centre + WINDOW[0] / 2 - start,
                  FLOOR_Y[storey] + WINDOW[1], FLOOR_Y[storey] + WINDOW[2])
                 for storey, a, plane, centre, _ in plan.windows if (a, plane) == (axis, line)]
        holes += [(centre - DOOR[0] / 2 - start, centre + DOOR[0] / 2 - start,
                   FLOOR_Y[storey], FLOOR_Y[storey] + DOOR[1])
                  for storey, a, plane, centre, _ in plan.entrances if (a, plane) == (axis, line)]
        name = f"outside_{'xz'[axis // 2]}{0 if line == 0 else 1}"
        parts.append((name, holed_rect(origin, along, (0, 1, 0), length, TOP, holes,
                                       building.TILE * 2, facing)))
    parts.append(("roof", quad([(x0, TOP, z0), (x1, TOP, z0), (x1, TOP, z1), (x0, TOP, z1)],
                               (0, 1, 0))))
    return parts


def _city_parts() -> list:
    """(name, (vertices, triangles)) of the city's buildings clear of W7's building, and the
    ground with a hole under the building (tiles of at most GROUND_TILE)."""
    foot = footprint()
    parts = []
    for index, house in enumerate(city.make_buildings()):
        corners = house.corners()
        if (corners.max(axis=0) >= foot[0] - LOT_CLEARANCE).all() and \
                (corners.min(axis=0) <= foot[1] + LOT_CLEARANCE).all():
            continue
        parts.append((f"building_{index:03d}", city.building_mesh(house)))
    low, high = city.city_extent()
    hole = (foot[0, 0] - low, foot[1, 0] - low, foot[0, 1] - low, foot[1, 1] - low)
    parts.append(("ground", holed_rect((low, 0.0, low), (1, 0, 0), (0, 0, 1), high - low,
                                       high - low, [hole], GROUND_TILE, (0, 1, 0))))
    return parts


def build_hybrid(plan: building.Plan | None = None, doors: str = "scheduled") -> tuple:
    """W7 at rest (doors closed, people and cars at their t = 0 poses) and its motion:
    (World, plan, leaves, motion document (crowd.motion_document; `doors` picks the doors'
    schedule: scheduled, open or closed)).

    Object order: the building (W1's objects, unpadded), its outside, the city, the doors, the
    people, the cars.
    """
    plan = plan or make_plan()
    inside, _ = building.build_building(target=None, plan=plan)
    mesh = MeshCollector()
    for name, (vertices, triangles) in _outer_walls(plan):
        mesh.add(name, np.asarray(vertices) + OFFSET, triangles)
    for name, part in _city_parts():
        mesh.add(name, *part)
    door_leaves = leaves(plan)
    for leaf in door_leaves:
        vertices, triangles = crowd.outward_boxes(leaf.box[None])
        mesh.add(leaf.name, vertices, triangles)
    people, cars = crowd.people(plan, OFFSET), crowd.cars()
    for name, vertices, triangles, _ in people + cars:
        mesh.add(name, vertices, triangles)
    moved = World(inside.vertices + OFFSET, inside.triangles, inside.object_ids,
                  list(inside.object_names), "w7")
    world = World.concatenate([moved, mesh.world("w7")], name="w7")
    return world, plan, door_leaves, crowd.motion_document(door_leaves, people, cars, doors)
