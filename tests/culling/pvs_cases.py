"""What the PVS tests share (test_pvs, test_pvs_storeys, test_pvs_leaves, test_pvs_frame,
test_pvs_doors): the zigzag rooms, cameras inside the view cells, and the check that a PVS
drops nothing the item buffer shows from them. Imported as `from .pvs_cases import ...`
(pytest's importlib mode names the test modules by their package path)."""
import numpy as np

from vismobile.culling import Culler, device_options
from vismobile.culling.pvs import packed_planes
from vismobile.culling.pvs_frame import near_plane
from vismobile.device.profile import get_profile
from vismobile.render import SENTINEL, item_buffer
from vismobile.world.camera import Camera

MODES = ("float64", "float32", "fixed16.16")


def zigzag_world(kit):
    """Five rooms 3 high and 4 deep in a row along x (faces in), split by hollow walls 0.2 thick
    at x = 4k (k = 1..4) whose doorways alternate between the two ends of each wall: from the
    first room the fourth and fifth are hidden. The cells are the rooms (cell faces x = 4k).
    Every surface is a grid of rectangles on common breaks, so walls meet floors, ceilings and
    each other corner to corner: only the doorways' edges are unshared (partition/pvs_cracks.py;
    a crease of T-junctions along the side walls would let a grazing line through every wall)."""
    rect, end = kit.rect, 20.2
    xs = [0.0] + [v for k in range(1, 5) for v in (4.0 * k, 4.0 * k + 0.2)] + [end]
    ys, zs = [0.0, 2.0, 3.0], [0.0, 0.2, 1.0, 3.0, 3.8, 4.0]
    spans = {name: list(zip(b[:-1], b[1:])) for name, b in (("x", xs), ("y", ys), ("z", zs))}
    parts = []
    for x in spans["x"]:
        for z in spans["z"]:
            parts += [rect(1, 0.0, z, x, 1), rect(1, 3.0, z, x, -1)]
        for y in spans["y"]:
            parts += [rect(2, 0.0, x, y, 1), rect(2, 4.0, x, y, -1)]
    for y in spans["y"]:
        for z in spans["z"]:
            parts += [rect(0, 0.0, y, z, 1), rect(0, end, y, z, -1)]
    for k in range(1, 5):
        door = (0.2, 1.0) if k % 2 else (3.0, 3.8)
        for x, facing in ((4.0 * k, -1), (4.0 * k + 0.2, 1)):
            parts += [rect(0, x, y, z, facing) for y in spans["y"] for z in spans["z"]
                      if not (y == (0.0, 2.0) and z == door)]
    return kit.literal_world(parts, name="zigzag")


SLABS = ((4 / 20.2, 4 / 20.2, 4 / 20.2, 4 / 20.2, 4.2 / 20.2), 1, 1)


def in_face_plane(part, cam) -> bool:
    """Whether the stage falls back for this eye as lying in the plane of a view cell's face
    (culling/pvs_frame.py near_plane: a wall there is edge-on): only when the bake did not walk the
    lines in those planes (no pvs_plane, partition/pvs_planes.py)."""
    cells = part.extras["pvs_cells"]
    return "pvs_plane" not in part.extras and \
        near_plane(*packed_planes([np.unique(cells[:, :, a]) for a in range(3)]),
                   np.asarray(cam.position, np.float64), 1e-6)


def in_cell_cameras(part, count, seed):
    """Cameras inside random view cells: uniform, on a face, on an edge or in a corner (each a
    quarter), yaw and pitch (up to +-89) and fov (10-120) at random, near 0.1 or 0.01."""
    rng = np.random.default_rng(seed)
    boxes = part.extras["pvs_cells"]
    cams = []
    for i in range(count):
        lo, hi = boxes[rng.integers(len(boxes))]
        t = rng.uniform(0, 1, 3)
        snap = rng.permutation(3)[:i % 4]  # 0..3 coordinates on the box's boundary
        t[snap] = rng.integers(0, 2, len(snap))
        pos = lo + t * (hi - lo)
        cams.append(Camera(pos, yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                           fov=rng.uniform(10, 120), near=float(rng.choice([0.1, 0.01])),
                           aspect=4 / 3))
    return cams


def near_boundary_cameras(part, count, seed):
    """Cameras 1 mm to 10 cm (at most a quarter of the cell) inside a face, an edge or a
    corner of random view cells (each a third), the rest as in_cell_cameras: past the stage's
    face reach (near_plane), so they use the cell's set right next to its boundary
    (tools/pvs_sweep.py's "near" kinds), where those exactly on it fall back."""
    rng = np.random.default_rng(seed)
    boxes = part.extras["pvs_cells"]
    cams = []
    for i in range(count):
        lo, hi = boxes[rng.integers(len(boxes))]
        pos = lo + rng.uniform(0, 1, 3) * (hi - lo)
        snap = rng.permutation(3)[:1 + i % 3]  # 1..3 of its sides near
        side = rng.integers(0, 2, len(snap)).astype(bool)
        gap = np.minimum(10.0 ** rng.uniform(-3, -1, len(snap)), 0.25 * (hi - lo)[snap])
        pos[snap] = np.where(side, hi[snap] - gap, lo[snap] + gap)
        cams.append(Camera(pos, yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                           fov=rng.uniform(10, 120), near=float(rng.choice([0.1, 0.01])),
                           aspect=4 / 3))
    return cams


def keeps_what_cameras_see(part, stages, cams, mode, profile) -> int:
    """Asserts that each culler of `stages` on part, in arithmetic `mode` (profile: the
    float64 profile the mode's is made from), keeps every triangle that mode's item buffer
    shows without back-face culling from each camera; returns how many (camera, stages) culls
    used the PVS (did not fall back)."""
    if mode != "float64":
        profile = get_profile(profile, mode)
    options = {"arithmetic": "float64"} if mode == "float64" else device_options(profile)
    cullers = {s: Culler(part, s, **options) for s in stages}
    used = 0
    for cam in cams:
        shown = np.unique(item_buffer(part.world, None, cam, profile, cull_back=False))
        shown = shown[shown != SENTINEL].astype(np.int64)
        for name, culler in cullers.items():
            result = culler.cull(cam)
            missing = np.setdiff1d(shown, result.triangles)
            assert not len(missing), f"{name} ({mode}, {part.world.name}) dropped {missing}: {cam}"
            used += "pvs.fallbacks" not in result.stats
    return used
