"""Doors (issue 25): the portals a closed door blocks for the `portals` stage.

A door is a moving object named DOOR_PREFIX... whose rest-pose triangles are a closed,
outward-wound box (its closed pose; the motion turns it about its hinge). find_doors picks them
out of an animated world; a `door_*` object that is not such a box is not a door (it never
blocks). At prepare, door_pairs lists the (portal, door) pairs whose portal polygon lies inside
the door's box, with how deep (the smallest distance from a portal vertex to the box's faces).

Per frame, portal p is blocked by door d when all three hold:
1. d is closed: its matrix at this time is the identity within CLOSED (a door turned by any
   visible amount, opening, open or moving, never blocks);
2. p lies inside d's box by more than `grow` (the device's move of a drawn vertex) plus what
   CLOSED lets the door move;
3. the eye lies outside d's box grown by `reach` (the near plane's reach plus the device's move)
   plus the same.
Then every sight line from the eye through a point of p enters d's closed box before reaching
that point: it meets the box's surface at a face seen from the front (the box is closed and
outward), not clipped by the near plane (3), so the item buffer shows the door there, never
what lies past p on that line. The door itself overlaps the cell on the eye's side of p (p's
plane cuts the box), so `portals` draws it (culling/moving.py keeps objects overlapping a
visible cell). Errs toward not blocking: a door blocks only portals wholly inside it.
"""
from __future__ import annotations

import numpy as np

from ..world.doors import (BOX_TOLERANCE, CLOSED, DOOR_PREFIX, door_pairs,  # noqa: F401
                          find_doors, is_box)


def closed_doors(matrices) -> tuple:
    """((D,) bool closed: every entry of M - I within CLOSED; (D,) float64 how far a closed
    door's vertices may have moved per unit of coordinate magnitude: 4 * max |M - I|)."""
    matrices = np.asarray(matrices, dtype=np.float64).reshape(-1, 4, 4)
    off = np.abs(matrices - np.eye(4)).reshape(len(matrices), -1).max(axis=1)
    return off <= CLOSED, 4.0 * off


def blocked(portals, doors, depths, boxes, closed, slack, eye, reach, grow) -> np.ndarray:
    """(B,) int64 portal ids blocked this frame (module docstring's rules 1-3).

    portals, doors, depths : door_pairs' output;  boxes (D, 2, 3) rest boxes;  closed (D,) bool
    and slack (D,) float64 (closed_doors, slack already times the coordinates' magnitude);
    eye (3,);  reach, grow : float world units (PortalStage.device_reach and the near reach)
    """
    if not len(portals):
        return np.zeros(0, dtype=np.int64)
    keep = shut(boxes, closed, slack, eye, reach)[doors] & (depths > grow + slack[doors])
    return np.unique(portals[keep])


def shut(boxes, closed, slack, eye, reach) -> np.ndarray:
    """(D,) bool doors that block their portals for this eye (rules 1 and 3: closed, the eye
    outside the box grown by reach + slack); rule 2 is each portal's own (blocked; the PVS
    bake checks it against its growth)."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    eye = np.asarray(eye, dtype=np.float64)
    margin = reach + np.asarray(slack, dtype=np.float64)  # (D,)
    away = ((eye < boxes[:, 0] - margin[:, None]) | (eye > boxes[:, 1] + margin[:, None])).any(axis=1)
    return np.asarray(closed, dtype=bool) & away


def attach_doors(stages, animated):
    """Give the `portals` and `pvs` stages among `stages` the doors of an AnimatedWorld
    (find_doors over its moving objects): (those stages, rows into the motion's matrices) for
    the Culler to hand each frame's door matrices on, or None without such a stage or a door."""
    users = [s for s in stages if s.name in ("portals", "pvs") and getattr(s, "available", False)]
    if not users:
        return None
    world = animated.world
    rows, boxes = find_doors(world.object_names, world.object_ids, world.corners,
                             animated.moving_object_ids)
    if not len(rows):
        return None
    for stage in users:
        stage.use_doors(boxes)
    return users, rows
