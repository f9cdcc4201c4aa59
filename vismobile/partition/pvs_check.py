"""The PVS extras' invariants (pvs.py's layout), checked on every load (base.Partition.check)."""
from __future__ import annotations

import numpy as np

from .pvs_codec import decode_all

NAMES = ("pvs_shape", "pvs_pack", "pvs_grow")


def check_pvs(x, triangles) -> None:
    """Raise ValueError when the PVS extras are inconsistent (loaded files are checked; the
    sets are inflated once to check them, within their declared size). pvs_cells, the boxes
    the .vmp keeps in pvs_pack (pvs_codec.derived_extras), must be the decoded ones."""
    if "pvs_runs" in x or "pvs_start" in x or (
            "pvs_cells" in x and np.asarray(x.get("pvs_shape", ())).shape not in ((9,), (10,))):
        raise ValueError("the PVS is stored in an older layout: bake it again")
    present = [n for n in NAMES if n in x]
    if not present:
        return
    if len(present) != len(NAMES):
        raise ValueError(f"pvs extras missing: {', '.join(n for n in NAMES if n not in x)}")
    grow = np.asarray(x["pvs_grow"])
    if "pvs_back" in x:
        back = np.asarray(x["pvs_back"])
        if back.shape != (1,) or not np.isfinite(back).all() or back[0] < 0:
            raise ValueError("pvs_back must be one finite non-negative value")
    if "pvs_cover" in x:
        cover = np.asarray(x["pvs_cover"])
        if cover.shape != (2,) or not np.isfinite(cover).all() or (cover <= 0).any():
            raise ValueError("pvs_cover must be two finite positive values (cover, near)")
    if grow.shape != (1,) or not np.isfinite(grow).all() or grow[0] < 0:
        raise ValueError("pvs_grow must be one finite non-negative value")
    boxes = decode_all(x, int(triangles))[0]
    if "pvs_cells" not in x or not np.array_equal(np.asarray(x["pvs_cells"]), boxes):
        raise ValueError("pvs_cells must be the view-cell boxes pvs_pack holds")
    check_door_sets(x, len(boxes), triangles)
    check_face_sets(x, boxes, triangles)


def check_face_sets(x, boxes, triangles) -> None:
    """The optional sets of lines lying in a face's plane (pvs_planes.face_extras): pvs_plane
    and pvs_face_planes together, pvs_face_shape and pvs_face_pack together and only with some
    plane, over the same view-cell boxes."""
    names = ("pvs_plane", "pvs_face_planes", "pvs_face_shape", "pvs_face_pack")
    present = [n in x for n in names]
    if not any(present):
        return
    if not (present[0] and present[1]) or present[2] != present[3]:
        raise ValueError("pvs face extras: pvs_plane and pvs_face_planes go together, and so do "
                         "pvs_face_shape and pvs_face_pack")
    plane = np.asarray(x["pvs_plane"])
    if plane.shape != (1,) or not np.isfinite(plane).all() or plane[0] < 0:
        raise ValueError("pvs_plane must be one finite non-negative value")
    planes = np.asarray(x["pvs_face_planes"])
    if planes.ndim != 2 or planes.shape[1] != 2 or not np.isfinite(planes).all() \
            or not np.isin(planes[:, 0], (0.0, 1.0, 2.0)).all():
        raise ValueError("pvs_face_planes must be (P, 2) finite rows (axis 0-2, coordinate)")
    if present[2] != (len(planes) > 0):
        raise ValueError("pvs_face_shape and pvs_face_pack go with some pvs_face_planes")
    if present[2]:
        face = decode_all({"pvs_shape": x["pvs_face_shape"], "pvs_pack": x["pvs_face_pack"]},
                          int(triangles))[0]
        if not np.array_equal(face, boxes):
            raise ValueError("pvs_face_pack must hold the view cells pvs_pack holds")


def check_door_sets(x, cells, triangles) -> None:
    """The optional door sets (pvs.door_sets): all three or none, offsets per (cell, door)."""
    names = ("pvs_door_boxes", "pvs_door_start", "pvs_door_runs")
    present = [n for n in names if n in x]
    if not present:
        return
    if len(present) != len(names):
        raise ValueError(f"pvs door extras missing: {', '.join(n for n in names if n not in x)}")
    boxes, start, runs = (np.asarray(x[n]) for n in names)
    if boxes.ndim != 3 or boxes.shape[1:] != (2, 3) or not np.isfinite(boxes).all() \
            or np.any(boxes[:, 0] > boxes[:, 1]):
        raise ValueError("pvs_door_boxes must be (D, 2, 3) finite boxes")
    start = start.astype(np.int64)
    if (start.shape != (cells * len(boxes) + 1,) or start[0] != 0 or start[-1] != len(runs)
            or np.any(np.diff(start) < 0) or np.any(start % 2)):
        raise ValueError("pvs_door_start must be even ascending offsets, one per cell and door")
    runs = runs.astype(np.int64)
    if runs.ndim != 1 or (len(runs) and (runs.min() < 0 or runs.max() > triangles)):
        raise ValueError("pvs_door_runs must be triangle ids")
    step = np.diff(runs)
    inner = np.ones(len(step), dtype=bool)
    cut = start[1:-1]
    inner[cut[(cut > 0) & (cut < len(runs))] - 1] = False
    if len(step) and np.any(step[inner] <= 0):
        raise ValueError("pvs_door_runs must be ascending, non-touching runs per cell and door")
