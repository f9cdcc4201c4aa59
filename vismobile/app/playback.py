"""Trajectory playback: cull and render every frame of a recorded path, log and summarise it.

The Controller of the thesis's runtime replaying a recorded path (SPEC §1, §6): per frame the
Culler picks the triangles (cull_ms), the Renderer draws them and waits on glFinish
(render_ms), and one row goes to frames.csv. summary.json holds mean, median and p95 of each
column, the fps and the Pearson correlation of frame_ms with triangles_sent. No figure holds
numba's first-use compile: WARM_FRAMES frames spread over the run are culled and drawn untimed
first (summary warmup_ms), and a cull that still compiles a path the warm-up missed is timed
again (timing.timed; summary compile_ms, what those first tries took).

frames.csv columns:
- cull_ms: Culler.cull wall time; render_ms: clear + index upload + draws + glFinish;
  summary.json also splits render_ms into upload_ms (index data built and written) and draw_ms
  (the rest: clear, draws, glFinish);
  frame_ms = cull_ms + render_ms (image read-back and file output are not timed);
- triangles_sent: triangles in this frame's index buffers;
- draw_batches: glDrawElements calls actually made (uint16 batches touched), not the
  Culler's count of id runs;
- nodes_visited: the Culler's counter (0 without a partition);
- memory_bytes: Profile.estimate_memory total (buffers sized for the worst frame, so constant);
- waypoint: the trajectory's label at this frame, or empty.
"""
from __future__ import annotations

import io
import json
import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..device.costmodel import DEVICES, device_counters, device_model, label, model_block
from ..errors import VisMobileError
from ..device.profile import get_profile
from ..progress import Progress
from ..stats import pearson, summarize
from ..timing import compile_seconds, timed
from ..world.trajectory import select_frames
from ..files.atomic import atomic_write_bytes, check_destination, staged_directory
from ..world.world import World

COLUMNS = ("frame", "cull_ms", "render_ms", "frame_ms", "triangles_sent", "draw_batches",
           "nodes_visited", "memory_bytes", "waypoint", "active_stages")
SUMMARISED = COLUMNS[1:8]
# Extra frames.csv columns of a run with level of detail (play --lod-tau).
LOD_COLUMNS = ("lod_ms", "triangles_full", "psnr_db", "max_diff", "changed")
STAGES_NONE = ("none", "")
# Frames culled and drawn, untimed, before the first measured one (spread over the run).
WARM_FRAMES = 9
# Frames in run.gif at most (its stride follows from the frames played).
GIF_FRAMES = 120


@dataclass
class Scene:
    """What playback draws: a world and its partition (None for --structure none); an
    animated scene (app/animation.py) also its AnimatedWorld (`world` is its rest pose,
    `partition` an AnimatedPartition) and frames per second (frame f at t = f / fps)."""

    world: World
    partition: object = None
    structure: str = "none"
    animated: object = None
    fps: float = 30.0


@dataclass
class PlaybackResult:
    """frames: {column: (F,) array}; summary: the summary.json dict; out: output folder."""

    frames: dict
    summary: dict
    out: Path | None = None
    images: dict = field(default_factory=dict)


def parse_stages(text) -> tuple:
    """'vfc,bfc,cbfc' or 'vfc+bfc+cbfc' -> ('vfc', 'bfc', 'cbfc'); 'none' or '' -> ()."""
    if isinstance(text, (tuple, list)):
        parts = [str(p) for p in text]
    else:
        parts = [p.strip() for p in str(text or "").replace("+", ",").split(",")]
    stages = tuple(p.lower() for p in parts if p.strip() and p.strip().lower() not in STAGES_NONE)
    if len(set(stages)) != len(stages):
        raise VisMobileError(f"culling stage listed twice in {text!r}")
    return stages


def parse_structure(text) -> tuple:
    """'octree:5' -> ('octree', {'depth': 5}); 'grid:8' -> ('grid', {'slabs': 8});
    'none' -> (None, {}): partition/spec.py's grammar; VisMobileError on a bad spec."""
    from ..partition.spec import parse_spec

    try:
        return parse_spec(text)
    except ValueError as error:
        raise VisMobileError(f"--structure {text}: {error}") from None


def load_scene(path, structure="none", progress=False, fix_winding=False, eyes=None,
               motion=None, fps=None, repair=None) -> Scene:
    """World (a mesh file, or a thesis world name w1..w7) partitioned by structure, or a .vmp file.

    fix_winding : reverse triangles first (winding.fixed_world); meshes only, not .vmp files
    eyes        : the camera positions fix_winding tells rooms from solids by (optional)
    repair      : None / "none" or "tjunctions" (files.loader.repaired); a .vmp keeps the world
                  it was built from, and refuses a repair it was not built with
    motion      : a JSON motion file moving the world's objects (else W7's own motion, or a
                  .glb/.gltf file's animation: app/animation.open_animated); fps: frames per
                  second of the trajectory's time (default: the motion's, else 30)

    Raises VisMobileError (WorldError, PartitionError, ...) naming the file or the bad setting.
    """
    path_text = str(path)
    if path_text.lower().endswith(".vmp"):
        from ..partition import load_partition

        if fix_winding:
            raise VisMobileError(f"{path_text}: --fix-winding applies to a mesh; a partition "
                                 "file keeps its world (fix it with partition --fix-winding)")

        if motion is not None:
            raise VisMobileError(f"{path_text}: --motion moves a world's objects; a partition "
                                 "file is static (give the mesh and --structure)")
        partition = load_partition(path_text)
        if repair not in (None, "none", partition.world.repair):
            raise VisMobileError(f"{path_text}: built without --repair {repair}; a partition "
                                 f"file keeps its world (rebuild it with partition --repair "
                                 f"{repair})")
        return Scene(partition.world, partition, _describe(partition.kind, partition.params))
    from ..files.loader import open_world
    from .animation import DEFAULT_FPS, check_fps, open_animated

    world = open_world(path_text, repair=repair)
    if fix_winding:
        from ..world.winding import fixed_world_said

        world = fixed_world_said(world, eyes)
    animated = open_animated(path_text, world, motion)
    if animated is not None and repair not in (None, "none"):
        raise VisMobileError(f"{path_text}: --repair applies to a static world, not to a "
                             "moving one (its motion names the original triangles)")
    if animated is not None:
        world = animated.world
    # frames per second: --fps, else the motion's own (a motion file's "fps"), else 30
    fps = check_fps(fps) if fps is not None else \
        animated.motion.fps if animated is not None else DEFAULT_FPS
    kind, params = parse_structure(structure)
    if kind is None:
        return Scene(world, None, "none", animated, fps)
    from ..partition import partition as build_partition

    bar = Progress(f"partition {kind}", enabled=None if progress else False)
    try:
        built = build_partition(animated if animated is not None else world, kind,
                                progress=bar, **params)
    except ValueError as error:  # unknown kind or parameter, parameter out of range
        raise VisMobileError(f"--structure {structure}: {error}") from None
    finally:
        bar.close()
    return Scene(world, built, _describe(kind, params), animated, fps)


def _describe(kind, params) -> str:
    """'octree:5' style label of a structure (partition/spec.py's canonical text)."""
    from ..partition.spec import format_spec

    return format_spec(kind, dict(params))


class _WholeWorld:
    """Culling without a partition: every triangle is sent; only bfc (a render flag) applies."""

    def __init__(self, world, stages):
        unsupported = [s for s in stages if s != "bfc"]
        if unsupported:
            raise VisMobileError(f"stage(s) {', '.join(unsupported)} need a partition; "
                                 "pass --structure (e.g. octree:5)")
        self.all = np.arange(world.triangle_count, dtype=np.int64)
        self.cull_back = "bfc" in stages

    def cull(self, camera, time=None):
        return _Culled(self.all, {"nodes_visited": 0, "triangles_sent": len(self.all)},
                       self.cull_back)


@dataclass
class _Culled:
    triangles: np.ndarray
    stats: dict
    cull_back: bool


def make_culler(scene: Scene, stages, profile=None, adaptive=False, regional=None):
    """vismobile.culling.Culler over the scene's partition, or all triangles without one.

    profile  : its arithmetic mode and screen go to the Culler (culling.device_options)
    regional : stage strings: a culling/regional.RegionalCuller picking per portal cell of the
               eye the cheapest of them (device model); `stages` is then ignored
    adaptive : wrap it in an AdaptiveCuller that switches off stages that stop paying; a dict
               is passed to AdaptiveCuller as keyword options (e.g. a clock for tests).
    """
    if scene.partition is None:
        return _WholeWorld(scene.world, stages)
    if "portals" in parse_stages(stages) and scene.partition.kind != "portal":
        raise VisMobileError(f"--cull portals needs a portal structure (--structure portal:N); "
                             f"this one is {scene.structure}")
    from ..culling import Culler, device_options
    from ..culling.adaptive import AdaptiveCuller

    options = device_options(profile) if profile is not None else {}

    def factory(partition, names):
        return Culler(partition, names, **options)

    if regional:
        from ..culling.regional import RegionalCuller

        if scene.partition.kind != "portal":
            raise VisMobileError(f"--regional picks per portal cell: it needs a portal "
                                 f"structure (--structure portal:N); this one is "
                                 f"{scene.structure}")
        try:
            return RegionalCuller(scene.partition, list(regional), culler_factory=factory)
        except ValueError as error:
            raise VisMobileError(f"--regional {';'.join(regional)}: {error}") from None
    try:
        if adaptive:
            tuning = adaptive if isinstance(adaptive, dict) else {}
            return AdaptiveCuller(scene.partition, parse_stages(stages), culler_factory=factory,
                                  **tuning)
        return factory(scene.partition, list(stages))
    except ValueError as error:  # unknown stage, or a stage the structure cannot run
        raise VisMobileError(f"--cull {'+'.join(stages)}: {error}") from None


def play(scene: Scene, trajectory, stages=(), profile="ipaq-hx2490b", out=None,
         frames_every=0, gif=False, hud=False, progress=False, frame_limit=None,
         gif_every=None, adaptive=False, frames="all", lod_tau=None,
         regional=None) -> PlaybackResult:
    """Play trajectory through the scene; write outputs to out (if given) atomically.

    stages       : culling stage names (see vismobile.culling), () for none
    profile      : Profile or profile name; the heap check runs before the first frame
    frames       : which frames to play: "all", "stride:N", "sample:N" (trajectory.select_frames)
    frames_every : save every Nth played frame as PNG (0: none)
    gif          : write run.gif of every gif_every-th played frame (default: the stride
                   giving at most GIF_FRAMES frames, independent of frames_every)
    hud          : draw the thesis HUD onto saved frames
    frame_limit  : play only the first frame_limit frames (>= 1), before `frames` selects
    out          : run folder; filled through a staging folder, summary.json last (atomic.py)
    progress     : draw a progress bar on stderr when it is a terminal
    adaptive     : switch stages off (and back on) while they cost more than they save; a dict
                   is passed to AdaptiveCuller as options; the switches go to summary.json
                   ("adaptive_events") and frames.csv (active_stages)
    regional     : stage strings; a RegionalCuller picks per portal cell the cheapest of them
                   (frames.csv active_stages names each frame's pick)
    lod_tau      : draw objects at the coarsest level whose error projects below lod_tau pixels
                   (the partition's LOD chains, built when it has none) and measure each
                   frame against the full-detail frame of the same culling (docs/lod.md);
                   None: no level of detail
    Raises ProfileError (heap, fixed16.16 range) before playing.
    """
    from ..render.textured import renderer_for
    from ..render.hud import draw_hud, hud_lines
    from ..render.images import png_bytes, save_gif

    profile = get_profile(profile)
    stages = parse_stages(stages)
    world = scene.world
    profile.check_range(world.extent, f"world {world.name!r}")
    lod_view = _lod_view(scene, profile, lod_tau, progress)
    memory = profile.check_memory(world, scene.partition)
    culler = make_culler(scene, stages, profile, adaptive, regional)
    renderer = lod_view.renderer if lod_view else renderer_for(world, profile)
    poser = None
    if scene.animated is not None:
        from .animation import Poser

        if lod_view:
            raise VisMobileError("--lod-tau draws static levels of detail; a scene whose "
                                 "objects move is played without it")
        poser = Poser(scene.animated, renderer)
    tree = getattr(culler, "tree", None)
    if tree is None and scene.partition is not None:  # the adaptive culler holds several
        from ..culling.tree import Tree

        tree = Tree(scene.partition)
    # The HUD's fps: the profile's device model when it has one, else this machine.
    hud_model = device_model(profile.name) if profile.name in DEVICES else None
    counters = []

    if frame_limit is not None and int(frame_limit) < 1:
        raise VisMobileError(f"frame limit must be at least 1, got {frame_limit}")
    if out is not None:
        check_destination(Path(out) / "summary.json")  # refuse a bad folder before playing
    count = len(trajectory) if frame_limit is None else min(int(frame_limit), len(trajectory))
    try:
        played = select_frames(frames, count, trajectory.waypoints)
    except ValueError as error:
        raise VisMobileError(f"--frames: {error}") from None
    count = len(played)
    labels = {int(f): label for label, f in trajectory.waypoints.items()}
    # The GIF has its own stride (not --images'): about GIF_FRAMES frames over the run.
    gif_every = int(gif_every or max(1, -(-count // GIF_FRAMES)))
    table = {name: np.zeros(count) for name in SUMMARISED + (LOD_COLUMNS if lod_view else ())}
    waypoints = [""] * count
    active = ["+".join(stages) or "none"] * count
    gif_images, saved = [], {}
    hud_ms = 0.0
    upload_ms = np.zeros(count)
    compiling = compile_seconds()
    warm = sorted(set(np.linspace(0, count - 1, WARM_FRAMES).astype(int))) if count else []
    warmup_ms = warm_up(scene, stages, profile, renderer,
                        [trajectory.camera(played[i], profile.aspect) for i in warm],
                        progress, world.name, [_time(scene, played[i]) for i in warm])
    warmup_compile_ms = (compile_seconds() - compiling) * 1000.0
    compile_ms, cpu_ms = 0.0, []
    bar = Progress(f"play {world.name}", enabled=None if progress else False)
    step = max(count // 200, 1)  # redraw the bar about 200 times
    for index, frame in enumerate(played):
        camera = trajectory.camera(frame, profile.aspect)
        cpu_start = time.process_time()  # every thread of this process: cull, llvmpipe
        # A cull that compiled a code path the warm-up missed is timed again (timing.timed).
        at = _time(scene, frame)
        culled, cull_ms, compiled = timed(_culls(culler, at), camera)
        # the drawn moving objects' vertices to this frame's pose (their upload)
        pose_ms = poser.pose(at, culled.triangles) if poser is not None else 0.0
        compile_ms += compiled
        if lod_view:
            lod = lod_view.draw(culled.triangles, camera, bool(culled.cull_back))
            drawn = lod.drawn
            for name, value in (("lod_ms", lod.lod_ms), ("triangles_full", lod.full_triangles),
                                ("psnr_db", lod.error["psnr_db"]),
                                ("max_diff", lod.error["max_diff"]),
                                ("changed", lod.error["changed"])):
                table[name][index] = value
            cull_ms += lod.lod_ms  # selection is part of the frame's CPU work
        else:
            drawn = renderer.draw(culled.triangles, camera, bool(culled.cull_back))
            if pose_ms:  # moving the objects' vertices is part of drawing the frame
                drawn = replace(drawn, render_ms=drawn.render_ms + pose_ms,
                                upload_ms=drawn.upload_ms + pose_ms)
        if adaptive and hasattr(culler, "observe_render"):
            culler.observe_render(drawn.render_ms, culled.stats)
        if adaptive or regional:
            active[index] = culled.stats.get("active_stages", active[index])
        frame_ms = cull_ms + drawn.render_ms
        if not compiled:
            cpu_ms.append((time.process_time() - cpu_start) * 1000.0)
        upload_ms[index] = drawn.upload_ms
        counters.append(device_counters(culled, tree))
        if lod_view:  # the device sends the levels' triangles
            counters[-1]["triangles_sent"] = drawn.triangles
        hud_ms += hud_model.frame_ms(counters[-1]) if hud_model else frame_ms
        row = (cull_ms, drawn.render_ms, frame_ms, drawn.triangles, drawn.draw_batches,
               culled.stats.get("nodes_visited", 0), memory)
        for name, value in zip(SUMMARISED, row):
            table[name][index] = value
        waypoints[index] = labels.get(frame, "")
        want_png = out is not None and frames_every and index % frames_every == 0
        want_gif = gif and index % gif_every == 0
        if want_png or want_gif:
            image = renderer.read_rgb()
            if hud:
                # fps averaged over the frames so far (one frame's fps jumps with warm-up).
                image = draw_hud(image, hud_lines(
                    stages, memory, drawn.triangles, 1000.0 * (index + 1) / max(hud_ms, 1e-9),
                    scene.structure, heap_bytes=profile.heap_bytes,
                    fps_label=label(profile.name if hud_model else None)))
            if want_png:
                saved[frame] = png_bytes(image, optimize=False)
            if want_gif:
                gif_images.append(image)
        if (index + 1) % step == 0 or index + 1 == count:
            bar(index + 1, count)
    bar.close()

    frames = {"frame": np.asarray(played, dtype=np.int64), **table, "waypoint": np.array(waypoints, dtype=object),
              "active_stages": np.array(active, dtype=object)}
    summary = summarise(frames)
    if count:
        summary["upload_ms"] = summarize(upload_ms)
        summary["draw_ms"] = summarize(table["render_ms"] - upload_ms)
    summary.update({
        "world": world.name, "triangles": world.triangle_count, "structure": scene.structure,
        "stages": list(stages), "profile": profile.name, "vertex_format": profile.vertex_format,
        "resolution": list(profile.resolution), "memory": profile.estimate_memory(
            world, scene.partition), "heap_bytes": profile.heap_bytes,
        # frame_ms, fps above are measured here; "model" is each device's model of the same
        # frames' counters (vismobile/device/costmodel.py).
        "timing": label(None), "model": model_block(counters),
        "adaptive": bool(adaptive), "adaptive_events": list(getattr(culler, "events", [])),
        "regional": {str(region): culler.choices[pick] for region, pick in
                     sorted(culler.decisions.items())} if regional else None,
        # an animated scene: objects moved (their vertex upload is in render_ms, upload_ms)
        "moving_objects": poser.count if poser is not None else 0,
        "scene_fps": scene.fps if poser is not None else None,
        # Untimed frames before the first measured one (numba's first-use compile, uploads).
        "warmup_ms": warmup_ms,
        "warmup_compile_ms": warmup_compile_ms,  # of it, inside numba's compiles
        # Compiles during measured frames (paths the warm-up missed): those culls were timed
        # again, and this is what the first tries took.
        "compile_ms": compile_ms,
        # CPU time of this process per frame (cull + draw, all its threads): what the frame
        # costs this machine, little moved by other processes' load, unlike the wall times.
        "cpu_ms": summarize(np.asarray(cpu_ms)) if cpu_ms else None,
    })
    if lod_view:
        summary.update(lod_summary(table, lod_tau))
    summary["warnings"] = path_warnings(world, trajectory, played, table["triangles_sent"])
    if summary["warnings"]:
        warnings.warn("; ".join(summary["warnings"]), stacklevel=2)
    result = PlaybackResult(frames, summary, Path(out) if out is not None else None)
    if out is not None:
        # Staged: a folder holding summary.json (written last) holds one whole run.
        with staged_directory(out, marker="summary.json") as stage:
            for frame, data in saved.items():
                atomic_write_bytes(stage / "frames" / f"frame_{frame:05d}.png", data)
            if gif and gif_images:
                save_gif(stage / "run.gif", gif_images)
            atomic_write_bytes(stage / "frames.csv", frames_csv(frames).encode("ascii"))
            atomic_write_bytes(stage / "summary.json",
                               (json.dumps(summary, indent=2, sort_keys=True) + "\n").encode())
    result.images = saved
    return result


def _time(scene, frame):
    """Seconds into an animated scene at a trajectory frame (frame / fps); None when static."""
    return None if scene.animated is None else float(frame) / scene.fps


def _culls(culler, at):
    """culler.cull of one camera at time `at` (None: a static scene's plain cull)."""
    if at is None:
        return culler.cull
    return lambda camera: culler.cull(camera, time=at)


def warm_up(scene, stages, profile, renderer, cameras, progress=False, name="",
            times=None) -> float:
    """Cull (with a throwaway culler) and draw each camera once, untimed, so no measured frame
    holds numba's first-use compile (tens of seconds on a fresh clone), lazy tables or the first
    uploads; the measured culler starts cold in its frame-to-frame state. Says "compiling
    (first run)" on stderr when it runs past progress.QUIET_SECONDS. Returns its wall ms."""
    from ..progress import Status

    start = time.perf_counter()
    with Status(f"play {name}", enabled=bool(progress)) as status:
        status("compiling (first run; later runs load numba's cache)")
        culler = make_culler(scene, stages, profile)
        for camera, at in zip(cameras, times or [None] * len(cameras)):
            culled = _culls(culler, at)(camera)
            renderer.draw(culled.triangles, camera, bool(culled.cull_back))
    return (time.perf_counter() - start) * 1000.0


def _lod_view(scene, profile, tau, progress):
    """A render.lod_view.LodView at tau pixels over the partition's LOD chains (built and
    attached to the partition when it has none, so the heap check counts them), or None."""
    if tau is None:
        return None
    tau = float(tau)
    if not np.isfinite(tau) or tau < 0:
        raise VisMobileError(f"--lod-tau must be a finite number of pixels >= 0, got {tau}")
    if scene.partition is None:
        raise VisMobileError("--lod-tau needs a partition (its LOD chains live beside it); "
                             "pass --structure (e.g. octree:5)")
    from ..lod.chains import LodChains
    from ..render.lod_view import LodView

    chains = LodChains.from_extras(scene.partition.extras)
    if chains is None:
        # Built once per world and kept beside the built worlds (<worlds>/lod/), like
        # compare's cache: W2's chains take one to four minutes to build.
        from ..progress import Status
        from ..scenes.thesis import default_cache_dir
        from ..study.engine import load_chains

        with Status("lod chains", enabled=bool(progress)) as status:
            status(f"level-of-detail chains of {scene.world.name} (built once, then cached)")
            chains = load_chains(scene.world, default_cache_dir())
        scene.partition.extras.update(chains.to_extras())
    return LodView(scene.world, chains, profile, tau)


def lod_summary(table, tau) -> dict:
    """summary.json's level-of-detail block: lod_tau, psnr_db_min, psnr_db_mean (PSNR of the
    mean squared error over the frames; null when every frame is bit-identical to the full-
    detail frame), the largest pixel difference, the mean fraction of pixels changed, the
    mean triangles of the full-detail frames and lod_ms statistics."""
    from ..lod.image_error import error_summary

    summary = error_summary(table["psnr_db"], table["max_diff"], table["changed"], tau)
    frames = len(table["psnr_db"])
    summary["triangles_full"] = summarize(table["triangles_full"]) if frames else None
    summary["lod_ms"] = summarize(table["lod_ms"]) if frames else None
    return summary


def path_warnings(world, trajectory, played, sent) -> list:
    """What suggests the trajectory is not for this world: the eye outside the world's box
    (x or z beyond it, or y below its floor or more than one world size above its top; above
    the top is allowed, for fly-overs; 1e-6 of the size of slack) on frames that send nothing
    (outside and seeing the world is a view of an object), and most frames sending no
    triangle. One clause each, for one warning line."""
    notes = []
    if not len(played):
        return notes
    low, high = world.extent
    size = float((high - low).max())
    slack = 1e-6 * size
    eyes = trajectory.poses[np.asarray(played, dtype=np.int64), :3]
    sent = np.asarray(sent)
    outside = ((eyes[:, [0, 2]] < low[[0, 2]] - slack) | (eyes[:, [0, 2]] > high[[0, 2]] + slack)
               ).any(axis=1) | (eyes[:, 1] < low[1] - slack) | (eyes[:, 1] > high[1] + size)
    lost = outside & (sent == 0)
    if lost.any():
        first = int(np.argmax(lost))
        x, y, z = eyes[first]
        notes.append(f"the camera is outside the world's bounds and sees nothing on "
                     f"{int(lost.sum())} of {len(played)} frames (first frame {played[first]} at "
                     f"({x:.4g}, {y:.4g}, {z:.4g}); the world spans ({low[0]:.4g}, {low[1]:.4g}, "
                     f"{low[2]:.4g}) to ({high[0]:.4g}, {high[1]:.4g}, {high[2]:.4g}))")
    empty = int((sent == 0).sum())
    if 2 * empty > len(played):
        notes.append(f"{empty} of {len(played)} frames sent no triangles")
    if notes:
        notes[-1] += ("; is the trajectory for this world? `vismobile trajectory generate` makes "
                      "one")
    return notes


def summarise(frames: dict) -> dict:
    """mean, median, p95 of each timing/counter column, fps and Pearson(frame_ms, triangles)."""
    summary = {"frames": int(len(frames["frame"]))}
    for name in SUMMARISED:
        summary[name] = summarize(frames[name]) if len(frames[name]) else None
    mean_ms = summary["frame_ms"]["mean"] if summary["frame_ms"] else 0.0
    summary["fps"] = 1000.0 / mean_ms if mean_ms > 0 else None
    summary["pearson_frame_ms_triangles"] = pearson(frames["frame_ms"], frames["triangles_sent"])
    return summary


def frames_csv(frames: dict) -> str:
    """frames.csv text: the COLUMNS header and one row per frame (then LOD_COLUMNS, for a run
    with level of detail; psnr_db "inf" on frames identical to the full-detail frame)."""
    buffer = io.StringIO()
    lod = "psnr_db" in frames
    buffer.write(",".join(COLUMNS + (LOD_COLUMNS if lod else ())) + "\n")
    for i in range(len(frames["frame"])):
        buffer.write(f"{frames['frame'][i]},{frames['cull_ms'][i]:.4f},{frames['render_ms'][i]:.4f},"
                     f"{frames['frame_ms'][i]:.4f},{int(frames['triangles_sent'][i])},"
                     f"{int(frames['draw_batches'][i])},{int(frames['nodes_visited'][i])},"
                     f"{int(frames['memory_bytes'][i])},{frames['waypoint'][i]},"
                     f"{frames['active_stages'][i]}")
        if lod:
            buffer.write(f",{frames['lod_ms'][i]:.4f},{int(frames['triangles_full'][i])},"
                         f"{frames['psnr_db'][i]:.3f},{int(frames['max_diff'][i])},"
                         f"{frames['changed'][i]:.6f}")
        buffer.write("\n")
    return buffer.getvalue()
