"""Generate trajectories/indoor.csv and outdoor.csv from waypoint keyframes, and measure the views.

Also their pitched variants indoor_pitched.csv and outdoor_pitched.csv (trajectory.pitch_sweep:
the same path looking up and down, +-85 degrees every 150 frames, and around, a turn every 420
frames); the indoor one also goes back down the ramp looking down at it and up again looking up
the stairwell (stairs()), inserted where the path reaches the landing.

Keyframes are (frame or None, x, z, yaw); frames left None are spread by path length and turn
between the fixed ones. Position and unwrapped yaw are interpolated with monotone cubic
(PCHIP) splines, so each coordinate stays between its neighbouring keyframes: a path whose
consecutive keyframes see each other in straight lines along the axes never cuts a wall.

Usage: python tools/make_trajectories.py [--measure]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.scenes import building, city  # noqa: E402
from vismobile.world.trajectory import Trajectory, pitch_sweep  # noqa: E402

EYE = 1.7


def pchip(knots, values, queries) -> np.ndarray:
    """Monotone cubic Hermite interpolation (Fritsch-Carlson): (Q,) float64, no overshoot."""
    x, y = np.asarray(knots, float), np.asarray(values, float)
    h = np.diff(x)
    delta = np.diff(y) / h
    slopes = np.zeros_like(y)
    w1, w2 = 2 * h[1:] + h[:-1], h[1:] + 2 * h[:-1]
    same = delta[:-1] * delta[1:] > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        harmonic = (w1 + w2) / (w1 / delta[:-1] + w2 / delta[1:])
    slopes[1:-1] = np.where(same, harmonic, 0.0)
    k = np.clip(np.searchsorted(x, queries, side="right") - 1, 0, len(h) - 1)
    t = (np.asarray(queries, float) - x[k]) / h[k]
    h00, h10 = (1 + 2 * t) * (1 - t) ** 2, t * (1 - t) ** 2
    h01, h11 = t * t * (3 - 2 * t), t * t * (t - 1)
    return h00 * y[k] + h10 * h[k] * slopes[k] + h01 * y[k + 1] + h11 * h[k] * slopes[k + 1]


def timed(keyframes, total: int, turn: float) -> np.ndarray:
    """(K, 4) float64 keyframes with every frame filled, spread by distance + turn * degrees."""
    keys = np.array([[np.nan if f is None else f, x, z, yaw] for f, x, z, yaw in keyframes])
    keys[:, 3] = np.degrees(np.unwrap(np.radians(keys[:, 3])))
    cost = np.r_[0.0, np.hypot(*np.diff(keys[:, 1:3], axis=0).T) + turn * np.abs(np.diff(keys[:, 3]))]
    fixed = np.flatnonzero(~np.isnan(keys[:, 0]))
    if fixed[0] != 0 or keys[fixed[-1], 0] != total - 1:
        raise ValueError("the first and last keyframes need fixed frames 0 and total-1")
    cumulative = np.cumsum(cost)
    for a, b in zip(fixed[:-1], fixed[1:]):
        span = cumulative[a:b + 1] - cumulative[a]
        keys[a:b + 1, 0] = keys[a, 0] + (keys[b, 0] - keys[a, 0]) * span / span[-1]
    return keys


def path(keyframes, total: int, turn: float) -> np.ndarray:
    """(total, 4) float64 per-frame x, z, yaw and the keyframe parameter."""
    keys = timed(keyframes, total, turn)
    frames = np.arange(total, dtype=float)
    return np.column_stack([pchip(keys[:, 0], keys[:, i], frames) for i in (1, 2, 3)])


def indoor() -> Trajectory:
    plan = building.make_plan()
    d = {name: plan.door(*spec).point() for name, spec in {
        "arch02": (0, (0, 1), (0, 2)), "d20": (0, (2, 0), (2, 1)), "d30": (0, (3, 0), (3, 1)),
        "u30": (1, (3, 0), (3, 1)), "u21": (1, (2, 1), (3, 1)), "u22": (1, (2, 1), (2, 2))}.items()}
    window = next(w[3] for w in plan.windows if w[0] == 0 and w[4] == (2, 0) and w[1] == 2)
    x_e = window - 3.0 if window - 3.0 > 15.2 else window + 3.0
    ramp = building.RAMP
    zr = (ramp["z0"] + ramp["z1"]) / 2
    keyframes = [
        (0, 2.0, 20.5, -90), (56, 5.5, 20.5, -90),  # A: the east wall of room (0,2)
        (None, 3.8, 21.0, -30), (124, 3.8, 20.8, 0),  # B: wall left, the arch right
        (None, d["arch02"][0], 18.5, 0), (None, d["arch02"][0], 15.0, 0),
        (None, 3.0, 12.5, -60), (229, 1.5, 12.5, -90),  # C: down the arched gallery
        (None, 4.0, 12.5, -60), (290, 4.0, 12.5, -45),  # D: the room's north-east corner
        (None, 7.0, 12.5, -90), (None, d["d20"][0], 12.5, -90), (None, d["d20"][0], 10.0, 0),
        (None, d["d20"][0], 6.0, 0), (462, x_e, 0.6, 0),  # E: close to the north outer wall
        (None, x_e, 2.5, 0), (None, d["d20"][0], 6.0, 180), (None, d["d20"][0], 10.0, 180),
        (None, d["d20"][0], 12.5, 90), (None, d["d30"][0], 12.5, 90),
        (None, d["d30"][0], 10.0, 0), (None, d["d30"][0], 5.0, 0), (None, 25.0, 3.0, 45),
        (None, 24.45, zr, -90), (None, 30.45, zr, -90),  # up the ramp
        (None, 30.45, 3.0, 180), (None, d["u30"][0], 6.0, 180), (None, d["u30"][0], 9.5, 180),
        (1000, 27.5, 10.5, 90),  # F: the west wall of room (3,1) upstairs
        (None, 25.5, d["u21"][2], 90), (None, 22.0, d["u21"][2], 90),
        (None, d["u22"][0], 15.0, 180), (None, d["u22"][0], 19.0, 180),
        (1413, 20.0, 20.5, 90),  # G: the west wall of room (2,2) upstairs
        (1475, 20.0, 20.5, 150),
    ]
    xzy = path(keyframes, 1476, turn=1 / 30)
    top = int(np.argmax(xzy[:, 0] >= 30.45 - 1e-6))  # first frame on the landing
    floor = plan.floor_height(xzy[:, 0], xzy[:, 1])
    floor[top:] = building.FLOOR_Y[1]
    poses = np.column_stack([xzy[:, 0], floor + EYE, xzy[:, 1], xzy[:, 2], np.zeros(len(xzy))])
    return Trajectory(poses, {"A": 56, "B": 124, "C": 229, "D": 290, "E": 462, "F": 1000,
                              "G": 1413})


def outdoor() -> Trajectory:
    street = city.block_origin(1) - city.STREET / 2  # 70: the street between block columns 0, 1
    east = city.block_origin(2) - city.STREET / 2  # 150
    keyframes = [
        (0, street, 250.0, 0), (None, street, 215.0, 0),
        (330, street, 200.0, 125),  # A: two corner buildings, the city edge behind them
        (None, street, 185.0, 60), (None, street, 135.0, 0),
        (428, street, 130.0, 90),  # B: two buildings close, a block behind them
        (None, street, 140.0, 0), (None, street, 150.0, -45),
        (719, street - 5.0, 150.0, -90),  # C: down the long street
        (None, east, 150.0, -90), (None, east, 115.0, 0),
        (1156, east, 110.0, 90),  # D: a building's wall, two blocks behind it
        (None, east, 100.0, 0), (None, east, -20.0, 0), (1998, east + 10.0, -30.0, -60),
    ]
    xzy = path(keyframes, 1999, turn=1 / 4)
    poses = np.column_stack([xzy[:, 0], np.full(len(xzy), EYE), xzy[:, 1], xzy[:, 2],
                             np.zeros(len(xzy))])
    return Trajectory(poses, {"A": 330, "B": 428, "C": 719, "D": 1156})


def hybrid() -> Trajectory:
    """W7's path (scenes/hybrid.py): down the street x = 70, in through the entrance, along the
    gallery, through the door into room (2, 0) and back, and out onto the street again."""
    from vismobile.scenes import hybrid as w7

    ox, oz = w7.OFFSET[0], w7.OFFSET[2]
    plan = w7.make_plan()
    door = plan.door(0, (2, 0), (2, 1))
    gz = oz + w7.ENTRANCE_CENTRE  # the gallery's axis (arches and entrance)
    dx = ox + door.centre  # the door into room (2, 0)
    keyframes = [
        (0, 70.0, 160.0, 0), (None, 70.0, 110.0, 0),  # A: down the street, the building left
        (None, 70.0, gz + 3.0, -45), (None, 72.0, gz, -90),
        (None, ox - 3.0, gz, -90),  # B: in front of the entrance
        (None, ox + 3.0, gz, -90), (None, ox + 10.0, gz, -90),  # C: in, down the gallery
        (None, dx, gz, -90), (None, dx, gz, 0),
        (None, dx, oz + door.plane + 2.0, 0), (None, dx, oz + 3.0, 0),  # D: through the door
        (None, dx, oz + 3.5, 180), (None, dx, gz, 180), (None, dx, gz, 90),
        (None, ox + 3.0, gz, 90), (None, ox - 3.0, gz, 90),  # E: back out
        (None, 68.0, gz, 90), (None, 68.0, gz - 4.0, 180), (1199, 68.0, gz + 30.0, 180),
    ]
    xzy = path(keyframes, 1200, turn=1 / 20)
    poses = np.column_stack([xzy[:, 0], np.full(len(xzy), EYE), xzy[:, 1], xzy[:, 2],
                             np.zeros(len(xzy))])
    half = xzy[:600]  # the way in: waypoints A-D
    near = lambda x, z: int(np.argmin(np.hypot(half[:, 0] - x, half[:, 1] - z)))  # noqa: E731
    return Trajectory(poses, {"A": near(70.0, 120.0), "B": near(ox - 3.0, gz),
                              "C": near(ox + 10.0, gz), "D": near(dx, oz + 3.0),
                              "E": 1100})


def stairs(inside: Trajectory, foot: int = 844, top: int = 876, frames: int = 90,
           turn: int = 15) -> np.ndarray:
    """(N, 5) poses of the stairs segment: from the landing (frame `top` of the indoor
    path) back down the ramp to its foot (frame `foot`) facing down it, pitch -35 to -60, a turn
    on the spot, and up again facing up it, pitch +35 to +60. Positions are resampled along the
    path's own ramp climb (free space), so the segment can be inserted after frame `top`."""
    climb = inside.poses[foot:top + 1, :3]
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(climb, axis=0), axis=1))])
    t = np.linspace(0.0, 1.0, frames)
    up_positions = np.column_stack([np.interp(t * along[-1], along, climb[:, k])
                                    for k in range(3)])
    down_positions = up_positions[::-1]
    bump = np.sin(np.pi * t)
    ahead = inside.poses[top, 3]  # facing up the ramp
    back = ahead + 180.0
    spin = np.linspace(back, back + 180.0, turn + 2)[1:-1]
    parts = [np.column_stack([down_positions, np.full(frames, back), -35.0 - 25.0 * bump]),
             np.column_stack([np.repeat(down_positions[-1:], turn, axis=0), spin,
                              np.zeros(turn)]),
             np.column_stack([up_positions, np.full(frames, ahead), 35.0 + 25.0 * bump])]
    poses = np.concatenate(parts)
    poses[:, 3] = np.mod(poses[:, 3] + 180.0, 360.0) - 180.0
    return poses


def indoor_pitched(inside: Trajectory, top: int = 876) -> Trajectory:
    """The indoor path looking up and down and around (pitch_sweep), with the stairs segment
    inserted after the landing frame `top`; waypoints after it move by the segment's length."""
    swept = pitch_sweep(inside)
    segment = stairs(inside, top=top)
    poses = np.concatenate([swept.poses[:top + 1], segment, swept.poses[top + 1:]])
    waypoints = {k: f + len(segment) if f > top else f for k, f in swept.waypoints.items()}
    return Trajectory(poses, waypoints)


def frustum_count(world, camera) -> int:
    """Triangles not wholly outside one frustum plane (a conservative in-frustum count)."""
    planes = camera.frustum_planes()
    corners = world.corners  # (T, 3, 3)
    signed = corners @ planes[:, :3].T + planes[:, 3]  # (T, 3, 6)
    return int((~(signed < 0).all(axis=1).any(axis=1)).sum())


def visible(world, camera, width=60, height=80) -> np.ndarray:
    """Unique triangle ids hit by a width x height grid of primary rays."""
    from vismobile.open3d_import import raycast_primitive_ids

    right, up, forward = camera.basis()
    ty = np.tan(np.radians(camera.fov) / 2)
    tx = ty * camera.aspect
    sx = (np.arange(width) + 0.5) / width * 2 - 1
    sy = (np.arange(height) + 0.5) / height * 2 - 1
    gx, gy = np.meshgrid(sx * tx, sy * ty)
    directions = forward + gx.reshape(-1, 1) * right + gy.reshape(-1, 1) * up
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = np.repeat(camera.eye[None], len(directions), axis=0)
    ids = raycast_primitive_ids(world.vertices, world.triangles, origins, directions)
    return ids


def measure(trajectory, worlds) -> None:
    for name, world in worlds.items():
        print(f"{name}: waypoint frame  in-frustum  visible  objects-visible  rays-missing")
        for label, frame in sorted(trajectory.waypoints.items(), key=lambda kv: kv[1]):
            camera = trajectory.camera(frame)
            ids = visible(world, camera)
            hit = np.unique(ids[ids >= 0])
            names = sorted({world.object_names[i] for i in world.object_ids[hit]})
            print(f"  {label} {frame:5d} {frustum_count(world, camera):10,d} {len(hit):8,d}"
                  f"  {len(names):3d} {(ids < 0).mean():5.0%}  {', '.join(names)[:90]}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--measure", action="store_true", help="print waypoint view counts")
    args = parser.parse_args(argv)
    inside, outside = indoor(), outdoor()
    folder = ROOT / "trajectories"
    inside.save(folder / "indoor.csv")
    outside.save(folder / "outdoor.csv")
    indoor_pitched(inside).save(folder / "indoor_pitched.csv")
    pitch_sweep(outside).save(folder / "outdoor_pitched.csv")
    hybrid().save(folder / "hybrid.csv")
    print(f"wrote trajectories/indoor.csv ({len(inside)} frames), outdoor.csv ({len(outside)} frames)"
          " and their _pitched variants, hybrid.csv (W7)")
    if args.measure:
        from vismobile.scenes import build_world

        measure(Trajectory.load(ROOT / "trajectories" / "indoor.csv"),
                {n: build_world(n) for n in ("w1", "w2")})
        measure(Trajectory.load(ROOT / "trajectories" / "outdoor.csv"),
                {n: build_world(n) for n in ("w5",)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
