"""What the `horizon` stage sends that no pixel shows, and why: on a world's path, every
triangle vfc+horizon+tbfc sends that the item buffer (back faces culled) does not show, sorted
into the reasons a horizon cannot or does not hide it.

    .venv/bin/python tools/horizon_escapes.py [--world w6] [--structure octree:5]
        [--trajectory trajectories/outdoor.csv] [--frames 120] [--screen]

--world terrain: tools/horizon_objects.py's terrain world with 60 models on its valley path
(--frames 40, as bench_cull.py runs it).

Per frame (means), by the triangle's object (an occluder the stage found: ground or building,
or a model by its name without digits) and reason:
- "no centre": its projected box holds no pixel centre of the profile's screen (sub-pixel);
- "object shows, box off the occluders": its object shows elsewhere and no occluder pixel lies
  under its box (the object's own hidden faces: no horizon hides them);
- "box on occluders": every pixel under its box shows an occluder (ground or building, drawn
  alone): hidden behind them or in front, where the 2.5D horizon (32 bands) is too coarse;
- "box partly on occluders", "crosses the near plane".
--screen culls with the profile's screen (device_options) too, so what is left after it shows.
"""
from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.culling import Culler, device_options  # noqa: E402
from vismobile.culling.horizon_solids import is_ground, is_prism  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.partition.spec import parse_spec  # noqa: E402
from vismobile.render import SENTINEL  # noqa: E402
from vismobile.render.item_buffer import item_buffer_renderer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402


def occluder_objects(world) -> set:
    """Object ids the stage takes as solids (horizon_solids' ground and prism tests)."""
    ids = np.asarray(world.object_ids)
    found = set()
    for obj in np.unique(ids):
        tris = np.flatnonzero(ids == obj)
        corners, normals = world.corners[tris], world.normals[tris]
        if is_ground(corners, normals) is not None or is_prism(corners, normals) is not None:
            found.add(int(obj))
    return found


def pixel_boxes(camera, corners, width, height) -> tuple:
    """(in front (K,), x0, x1, y0, y1 (K,)) window boxes of triangles (K, 3, 3), row 0 on top."""
    h = np.c_[corners.reshape(-1, 3), np.ones(corners.shape[0] * 3)] @ camera.view_projection().T
    h = h.reshape(-1, 3, 4)
    front = (h[..., 3] > 1e-9).all(axis=1)
    w = np.where(h[..., 3] > 1e-9, h[..., 3], 1.0)
    px = (h[..., 0] / w + 1.0) * 0.5 * width
    py = (1.0 - h[..., 1] / w) * 0.5 * height
    return front, px.min(1), px.max(1), py.min(1), py.max(1)


def escapes(world, cameras, part, profile, screen=False) -> tuple:
    """(mean sent by vfc,tbfc, by vfc,horizon,tbfc, mean shown, Counter of (object, reason)
    summed over the cameras)."""
    options = device_options(profile) if screen else {"arithmetic": profile.vertex_format}
    culler = Culler(part, "vfc,horizon,tbfc", **options)
    base = Culler(part, "vfc,tbfc", arithmetic=profile.vertex_format)
    renderer = item_buffer_renderer(world, profile)
    width, height = profile.resolution
    ids = np.asarray(world.object_ids)
    solid = occluder_objects(world)
    solid_tris = np.flatnonzero(np.isin(ids, sorted(solid)))
    everything = np.arange(world.triangle_count)
    counts, sent, plain, shown = collections.Counter(), 0, 0, 0
    for cam in cameras:
        kept = culler.cull(cam).triangles
        plain += len(base.cull(cam).triangles)
        seen = renderer.visible(everything, cam, True)
        sent += len(kept)
        shown += len(seen)
        unseen = np.setdiff1d(kept, seen)
        seen_objects = set(ids[seen].tolist())
        occluders = renderer.render(solid_tris, cam, True) != SENTINEL
        front, x0, x1, y0, y1 = pixel_boxes(cam, world.corners[unseen], width, height)
        i0, i1 = np.ceil(x0 - 0.5), np.floor(x1 - 0.5)
        j0, j1 = np.ceil(y0 - 0.5), np.floor(y1 - 0.5)
        for k, t in enumerate(unseen):
            obj = int(ids[t])
            kind = "occluder" if obj in solid else world.object_names[obj].rstrip("0123456789_")
            if not front[k]:
                reason = "crosses the near plane"
            elif i1[k] < i0[k] or j1[k] < j0[k]:
                reason = "no centre"
            else:
                a0, a1 = int(max(i0[k], 0)), int(min(i1[k], width - 1))
                b0, b1 = int(max(j0[k], 0)), int(min(j1[k], height - 1))
                under = occluders[b0:b1 + 1, a0:a1 + 1]
                if under.size and under.all():
                    reason = "box on occluders"
                elif under.size and under.any():
                    reason = "box partly on occluders"
                elif obj in seen_objects:
                    reason = "object shows, box off the occluders"
                else:
                    reason = "object hidden, box off the occluders"
            counts[(kind, reason)] += 1
    n = len(cameras)
    return plain / n, sent / n, shown / n, counts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="w6")
    ap.add_argument("--structure", default="octree:5")
    ap.add_argument("--trajectory", default=str(ROOT / "trajectories" / "outdoor.csv"))
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--profile", default="ipaq-hx2490b")
    ap.add_argument("--screen", action="store_true",
                    help="cull with the profile's screen too (device_options)")
    args = ap.parse_args(argv)
    profile = get_profile(args.profile)
    if args.world == "terrain":  # horizon_objects.py's terrain world on its valley path
        from horizon_objects import terrain_objects_world

        from vismobile.terrain.paths import path_cameras

        world, hm = terrain_objects_world()
        cameras = path_cameras(hm, "valley", "fast", frames=args.frames, eye_height=2.0,
                               aspect=profile.aspect, every=max(1, 240 // args.frames))
        args.trajectory = "valley"
    else:
        world = build_world(args.world)
        traj = Trajectory.load(args.trajectory)
        frames = np.unique(np.linspace(0, len(traj) - 1, args.frames).astype(int))
        cameras = [traj.camera(int(f), profile.aspect) for f in frames]
    kind, params = parse_spec(args.structure)
    part = partition(world, kind, **params)
    plain, sent, shown, counts = escapes(world, cameras, part, profile, args.screen)
    n = len(cameras)
    print(f"{args.world.upper()} {args.structure}, {n} frames of {Path(args.trajectory).name}"
          f"{' @screen' if args.screen else ''}: vfc,tbfc sends {plain:.1f}, vfc,horizon,tbfc "
          f"{sent:.1f} ({sent / max(plain, 1):.3f}x), {shown:.1f} shown, {sent - shown:.1f} "
          f"unseen a frame\n\n| object | reason | unseen sent a frame |\n| --- | --- | ---: |")
    for (obj, reason), count in sorted(counts.items(), key=lambda kv: -kv[1]):
        print(f"| {obj} | {reason} | {count / n:.1f} |")
    kinds = collections.Counter()  # occluders against models, by reason
    for (obj, reason), count in counts.items():
        kinds[("occluder" if obj == "occluder" else "model", reason)] += count
    print("\n| occluder or model | reason | unseen sent a frame |\n| --- | --- | ---: |")
    for (obj, reason), count in sorted(kinds.items(), key=lambda kv: -kv[1]):
        print(f"| {obj} | {reason} | {count / n:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
