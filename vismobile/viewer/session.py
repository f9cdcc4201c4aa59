"""Everything the viewer knows and does, without a window: the world and its structures, the
Culler for the active stages, the camera driven by the joystick or by a trajectory, the
recorder, the overlays; render() culls and draws one frame and returns it as arrays."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..world.camera import Camera
from ..errors import ProfileError, VisMobileError
from ..app.playback import Scene, load_scene, make_culler, parse_structure, _describe
from ..device.profile import get_profile
from ..world.trajectory import Trajectory
from . import keys
from .controls import Speeds, mouse_look, overview_pose, step_pose
from .layout import PANEL as GOD
from .godview import VIEWS, GodView

# Level-of-detail tolerances the T key cycles through (None: off), pixels.
LOD_TAUS = (None, 0.5, 1.0, 2.0, 4.0, 8.0)
from .hud import hud_lines
from .recorder import Player, Recorder

# Tab cycles through these (built on first use), from the session's first structure.
STRUCTURES = ("none", "grid", "octree:4", "octree:5", "portal:1", "bsp", "kdtree")
GOD_VIEWS = tuple(VIEWS) + (None,)
# A tap of a held key (down and up between two frames) moves the camera this many seconds'
# worth, one step.
TAP_SECONDS = 0.1


def start_pose(world) -> np.ndarray:
    """(5,) the first pose of the walk `vismobile trajectory generate` makes (seed 0): inside
    an indoor world at eye height, above an outdoor one; the overview pose when there is no
    free space to walk."""
    from ..app.walk import walk

    try:
        poses, _, _ = walk(world, frames=2, seed=0)
    except VisMobileError:
        return overview_pose(world.extent)
    return poses[0].copy()


@dataclass
class Frame:
    """One rendered frame.

    image     : (H, W, 3) uint8 at the render resolution, row 0 = top
    god       : (h, w, 3) uint8 god view, or None when it is off
    hud       : list of HUD text lines; info: the figures behind them
    camera    : the Camera drawn; triangles: (S,) int64 ids sent; stats: the Culler's counters
    """

    image: np.ndarray
    god: np.ndarray | None
    hud: list
    info: dict
    camera: object
    triangles: np.ndarray
    stats: dict = field(default_factory=dict)


class Session:
    """The viewer's state; key_down/key_up/press/drag change it, update(dt) moves time on,
    render() draws. Rendering needs the headless GL context current (window.py makes it so).

    scene      : playback.Scene (world + first partition); structures: the Tab cycle
    stages     : culling stage names active at start
    profile    : Profile or name; frames render at its resolution (set_view_size changes it
                 for `desktop`, whose frames fill the window)
    trajectory : path of a trajectory CSV that L loads (and that sets the first pose)
    record_path: where V saves the recording
    """

    def __init__(self, scene: Scene, stages=(), profile="ipaq-hx2490b", trajectory=None,
                 record_path="recorded.csv", structures=STRUCTURES, god_size=(GOD, GOD),
                 start="overview"):
        from ..app.playback import parse_stages

        self.world = scene.world
        # an animated scene (issue 25): its objects move with the scene's clock (fly: wall
        # time; playback: frame / fps); the renderer's copy is posed each frame
        self.animated, self.fps, self.clock = scene.animated, scene.fps, 0.0
        self._poser = None
        self.profile = get_profile(profile)
        self.profile.check_range(self.world.extent, f"world {self.world.name!r}")
        self.profile.check_memory(self.world, scene.partition)  # refused, as `play` refuses
        self.partitions = {scene.structure: scene.partition}
        self.structures = list(dict.fromkeys(self._label(s) for s in structures))
        if scene.structure not in self.structures:
            self.structures.insert(0, scene.structure)
        self.structure = scene.structure
        self.stages = tuple(parse_stages(stages))
        self._cullers = {}
        self.culler = self._culler(self.structure, self.stages)  # bad stages fail at start
        self.speeds = Speeds.for_extent(self.world.extent)
        self.trajectory_path = Path(trajectory) if trajectory is not None else None
        self.record_path = Path(record_path)
        self.recorder = Recorder()
        self.player = None
        self._mode = "fly"  # or "play": the player drives the camera (see mode)
        self.held = set()
        self.unmoved = set()  # held actions pressed since the last update
        self.shots = 0
        self.last_frame = None
        self.frame = 0
        self.running = True
        self.show_culled = False
        self.show_nodes = False
        self.show_help = False
        self.god_view = "top"
        self.message = ""
        self.lod_tau = None  # level of detail off; T cycles LOD_TAUS
        self._lod = None  # render.lod_view.LodView of the current tau
        # Tab builds a structure not built yet on a thread while frames go on (the window sets
        # this; scripted runs and tests switch at once, deterministically).
        self.background_builds = False
        self._pending = None  # (label, thread, {"partition" or "error"}) of a build under way
        self._god = GodView(self.world, god_size)
        self._renderer = None
        self._model = None
        if self.profile.cost is not None:
            from ..device.costmodel import device_model

            self._model = device_model(self.profile.name)
        if self.trajectory_path is not None:
            first = Trajectory.load(self.trajectory_path)
            self.pose = first.poses[0].copy()
        else:
            self.pose = start_pose(self.world) if start == "walk" else \
                overview_pose(self.world.extent)

    @classmethod
    def open(cls, world, structure="none", stages=(), profile="ipaq-hx2490b", trajectory=None,
             fix_winding=False, motion=None, fps=None, **options) -> "Session":
        """Session of a world (mesh file, .vmp or thesis name w1..w6) partitioned by structure;
        fix_winding reverses triangles first (winding.fixed_world, meshes only)."""
        eyes = None
        if fix_winding and trajectory is not None:
            eyes = Trajectory.load(trajectory).poses[:, :3]
        options.setdefault("start", "walk")  # no trajectory: start inside, as the walk would
        return cls(load_scene(world, structure, fix_winding=fix_winding, eyes=eyes,
                              motion=motion, fps=fps), stages, profile, trajectory, **options)

    # ---- structures and stages -------------------------------------------------------------
    @staticmethod
    def _label(structure) -> str:
        kind, params = parse_structure(structure)
        return "none" if kind is None else _describe(kind, params)

    def _partition(self, label):
        if label not in self.partitions and label == "none":
            self.partitions[label] = None
        elif label not in self.partitions:
            from ..partition import partition as build

            kind, params = parse_structure(label)
            try:
                self.partitions[label] = build(self.animated or self.world, kind, **params)
            except ValueError as error:
                raise VisMobileError(f"structure {label}: {error}") from None
        return self.partitions[label]

    def _build_in_background(self, label) -> None:
        import threading

        outcome = {}

        def build():
            try:
                outcome["partition"] = self._partition(label)
            except VisMobileError as error:
                outcome["error"] = str(error)

        thread = threading.Thread(target=build, name=f"build {label}", daemon=True)
        self._pending = (label, thread, outcome)
        self.message = f"building {label} ..."
        thread.start()

    def _finish_build(self) -> None:
        """Switch to the structure whose background build has ended (or say why not)."""
        label, thread, outcome = self._pending
        if thread.is_alive():
            return
        self._pending = None
        if "error" in outcome:
            self.message = outcome["error"]
        else:
            self.set_structure(label)

    def _culler(self, label, stages):
        key = (label, tuple(sorted(stages)))
        if key not in self._cullers:
            scene = Scene(self.world, self._partition(label), label, self.animated, self.fps)
            self._cullers[key] = make_culler(scene, stages, self.profile)
        return self._cullers[key]

    def set_stages(self, stages) -> bool:
        """Switch to these stages; False (and a message) when the structure cannot run them."""
        try:
            self.culler = self._culler(self.structure, tuple(stages))
        except VisMobileError as error:
            self.message = str(error)
            return False
        self.stages = tuple(stages)
        return True

    def toggle_stage(self, stage) -> bool:
        """Switch one stage on or off; False when the structure cannot run the result."""
        stages = tuple(s for s in self.stages if s != stage) if stage in self.stages \
            else self.stages + (stage,)
        if self.set_stages(stages):
            self.message = f"{stage} {'on' if stage in stages else 'off'}"
            return True
        return False

    def set_structure(self, structure) -> bool:
        """Switch structure keeping the stages that it can run (others are switched off);
        False (and a message) when the world with it does not fit the profile's heap."""
        label = self._label(structure)
        try:
            self.profile.check_memory(self.world, self._partition(label))
        except ProfileError as error:
            self.message = f"structure {label} not switched to: {error}"
            return False
        kept = self.stages
        try:
            self.culler = self._culler(label, kept)
        except VisMobileError:  # e.g. portals on an octree: keep the stages it can run
            kept = tuple(s for s in self.stages if self._runs(label, s))
            self.culler = self._culler(label, kept)
        dropped = [s for s in self.stages if s not in kept]
        self.structure, self.stages = label, tuple(kept)
        self.message = f"structure {label}" + (f" ({', '.join(dropped)} off)" if dropped else "")
        return True

    def _runs(self, label, stage) -> bool:
        try:
            self._culler(label, (stage,))
            return True
        except VisMobileError:
            return False

    def next_structure(self) -> None:
        """The next structure of the Tab cycle that fits the heap (the message names any
        skipped). With background_builds, one not built yet is built on a thread and switched
        to when ready (update)."""
        if self._pending is not None:
            self.message = f"still building {self._pending[0]}"
            return
        index = self.structures.index(self.structure)
        skipped = []
        for step in range(1, len(self.structures)):
            label = self.structures[(index + step) % len(self.structures)]
            if self.background_builds and label not in self.partitions:
                self._build_in_background(label)
                break
            if self.set_structure(label):
                break
            skipped.append(label)
        if skipped:
            self.message += f"; over the {self.profile.heap_bytes >> 20} MB heap: " + \
                ", ".join(skipped)

    # ---- input -----------------------------------------------------------------------------
    def key_down(self, name: str) -> None:
        """A key went down: held actions start, one-shot actions run."""
        held = keys.action_held(name)
        if held is not None:
            self.held.add(held)
            self.unmoved.add(held)  # until an update moves it: a tap still moves one step
        pressed = keys.action_pressed(name)
        if pressed is not None:
            self.press(pressed)

    def key_up(self, name: str) -> None:
        """A key went up: its held action stops; a tap (down and up before any update) moves
        the camera one step of TAP_SECONDS, so a single press of Up moves."""
        held = keys.action_held(name)
        if held is not None:
            self.held.discard(held)
            if held in self.unmoved and self.mode == "fly":
                self.pose = step_pose(self.pose, {held}, TAP_SECONDS, self.speeds)
            self.unmoved.discard(held)

    def drag(self, dx: float, dy: float) -> None:
        """Mouse look by a drag of (dx, dy) pixels (flying only)."""
        if self.mode == "fly":
            self.pose = mouse_look(self.pose, dx, dy, self.speeds)

    def press(self, action: str) -> None:
        """Run a one-shot action (keys.PRESSED values)."""
        if action.startswith("toggle:"):
            self.toggle_stage(action.split(":", 1)[1])
        elif action == "next_structure":
            self.next_structure()
        elif action == "record":
            if self.recorder.on:
                self.recorder.stop()
                self.message = f"recorded {len(self.recorder)} poses (V saves)"
            else:
                self.recorder.start()
                self.message = "recording"
        elif action == "save":
            self.save_recording()
        elif action == "load":
            self.load_trajectory()
        elif action == "play":
            if self.player is None:
                self.message = "no trajectory loaded (L loads one)"
            elif self.mode == "fly":
                self.player.paused = False
                self._mode = "play"
            else:
                self._mode = "fly"
        elif action == "pause":
            if self.player is not None and self.mode != "fly":
                self.player.paused = not self.player.paused
        elif action in ("step_forward", "step_back"):
            if self.player is not None and self.mode != "fly":
                self.player.paused = True
                self.player.step(1 if action == "step_forward" else -1)
                self.pose = self.player.pose()
        elif action == "show_culled":
            self.show_culled = not self.show_culled
        elif action == "show_nodes":
            self.show_nodes = not self.show_nodes
        elif action == "lod_tau":
            self.set_lod_tau(LOD_TAUS[(LOD_TAUS.index(self.lod_tau) + 1) % len(LOD_TAUS)]
                             if self.lod_tau in LOD_TAUS else LOD_TAUS[1])
        elif action == "god_view":
            self.god_view = GOD_VIEWS[(GOD_VIEWS.index(self.god_view) + 1) % len(GOD_VIEWS)]
        elif action == "help":
            self.show_help = not self.show_help
        elif action == "screenshot":
            self.save_screenshot()
        elif action == "quit":
            self.running = False
        elif action == "terrain_method":
            self.message = "M switches a terrain's LOD method (view a .vmt)"
        else:
            raise ValueError(f"unknown viewer action {action!r}")

    def set_lod_tau(self, tau) -> None:
        """Level of detail at tau pixels (None: off). The chains come from the partition's
        extras (partition --lod), else from the cache beside the built worlds, else they are
        built (once per world: W2 takes minutes) and cached."""
        if tau is not None and self.animated is not None:
            self.message = "level of detail is for static scenes; these objects move"
            return
        self.lod_tau = None if tau is None else float(tau)
        if self.lod_tau is None:
            self.message = "level of detail off"
            return
        if self._lod is None:
            from ..lod.chains import LodChains
            from ..render.lod_view import LodView
            from ..scenes.thesis import default_cache_dir
            from ..study.engine import load_chains

            partition = self.partitions.get(self.structure)
            extras = partition.extras if partition is not None else {}
            chains = LodChains.from_extras(extras)
            if chains is None:  # built once per world, then loaded (<worlds>/lod/), as play
                chains = load_chains(self.world, default_cache_dir())
                if partition is not None:
                    extras.update(chains.to_extras())
            self._lod = LodView(self.world, chains, self.profile, self.lod_tau, reference=False)
        self._lod.tau = self.lod_tau
        self.message = f"level of detail: tau {self.lod_tau:g} px"

    # ---- trajectories ----------------------------------------------------------------------
    @property
    def mode(self) -> str:
        """"fly" (joystick), "play" or "pause" (trajectory playback)."""
        if self._mode == "play" and self.player is not None and self.player.paused:
            return "pause"
        return self._mode

    def save_recording(self, path=None) -> Path | None:
        """Save the recording (trajectory CSV); L then loads it. None when nothing recorded."""
        path = Path(path) if path is not None else self.record_path
        if not len(self.recorder):
            self.message = "nothing recorded (R starts recording)"
            return None
        self.recorder.save(path)
        self.trajectory_path = path
        self.message = f"saved {len(self.recorder)} poses to {path}"
        return path

    def load_trajectory(self, path=None) -> bool:
        """Load a trajectory CSV and play it from its first frame; False with a message when
        there is none or it is malformed."""
        path = Path(path) if path is not None else self.trajectory_path
        if path is None:
            self.message = "no trajectory file (--trajectory, or record and save one)"
            return False
        try:
            trajectory = Trajectory.load(path)
        except VisMobileError as error:
            self.message = str(error)
            return False
        self.player = Player(trajectory)
        self._mode = "play"
        self.pose = self.player.pose()
        self.message = f"playing {path} ({len(trajectory)} frames)"
        return True

    def save_screenshot(self, path=None) -> Path | None:
        """The last frame's view (render resolution) as PNG: path, or the next free
        vismobile-NNN.png beside the recording; the message says where."""
        if self.last_frame is None:
            self.message = "no frame drawn yet"
            return None
        from ..files.atomic import atomic_write_bytes
        from ..render.images import png_bytes

        if path is None:
            while True:
                self.shots += 1
                path = self.record_path.parent / f"vismobile-{self.shots:03d}.png"
                if not path.exists():
                    break
        path = Path(path)
        atomic_write_bytes(path, png_bytes(self.last_frame.image, optimize=False))
        self.message = f"saved {path}"
        return path

    # ---- time and drawing ------------------------------------------------------------------
    def update(self, dt: float) -> None:
        """Move time on by dt seconds: the joystick moves the camera, or playback advances
        one frame (the trajectory has one pose per frame, as the thesis's did)."""
        if self._pending is not None:
            self._finish_build()
        if self.mode == "play":
            if self.player.finished:
                self.player.paused = True
            self.player.advance()
            self.pose = self.player.pose()
        elif self.mode == "fly":
            self.pose = step_pose(self.pose, self.held, dt, self.speeds)
        self.clock += max(float(dt), 0.0)
        self.unmoved.clear()
        self.recorder.add(self.pose)
        self.frame += 1

    def camera(self):
        """The Camera of the current pose at the render aspect (playback: the trajectory's)."""
        aspect = self.profile.aspect
        if self.mode != "fly":
            return self.player.trajectory.camera(self.player.frame, aspect)
        x, y, z, yaw, pitch = self.pose
        return Camera((x, y, z), yaw, pitch, aspect=aspect)  # fov, near, far as trajectories

    def set_view_size(self, width: int, height: int) -> None:
        """For the `desktop` profile frames fill the window: render at its size."""
        if self.profile.name == "desktop" and (width, height) != self.profile.resolution \
                and width > 0 and height > 0:
            self.profile = self.profile.with_(resolution=(int(width), int(height)))
            self._renderer = None
            if self._lod is not None:  # the levels' renderer follows the new size
                from ..render.lod_view import LodView

                self._lod = LodView(self.world, self._lod.selector.chains, self.profile,
                                    self._lod.tau, reference=False)

    @property
    def renderer(self):
        if self._renderer is None:
            from ..render import Renderer

            self._renderer = Renderer(self.world, self.profile)
        return self._renderer

    def scene_time(self):
        """Seconds into an animated scene: the played frame / fps, or the clock while flying;
        None for a static scene."""
        if self.animated is None:
            return None
        return self.player.frame / self.fps if self.mode != "fly" else self.clock

    def render(self) -> Frame:
        """Cull and draw the current camera; overlays and god view added (not timed)."""
        camera = self.camera()
        at = self.scene_time()
        start = time.perf_counter()
        culled = self.culler.cull(camera) if at is None else self.culler.cull(camera, time=at)
        cull_ms = (time.perf_counter() - start) * 1000.0
        pose_ms = 0.0
        if at is not None:  # the drawn moving objects' vertices to this frame's pose
            from ..app.animation import Poser

            if self._poser is None or self._poser.renderer is not self.renderer:
                self._poser = Poser(self.animated, self.renderer)
            # the culled overlay draws what was not sent too: then every object is posed
            pose_ms = self._poser.pose(at, None if self.show_culled else culled.triangles)
        renderer = self.renderer
        selection = None
        if self.lod_tau is not None and self._lod is not None:
            renderer = self._lod.renderer
            selection = self._lod.draw(culled.triangles, camera, bool(culled.cull_back))
            drawn, selection = selection.drawn, selection.selection
        else:
            drawn = renderer.draw(culled.triangles, camera, bool(culled.cull_back))
        nodes = getattr(culled, "nodes", None)
        culled_ids = None
        if self.show_culled:
            keep = np.ones(self.world.triangle_count, dtype=bool)
            keep[culled.triangles] = False
            culled_ids = np.flatnonzero(keep)
        from ..render.overlay import draw_boxes, flat_mask, tint

        if self.show_nodes and nodes is not None and len(nodes):
            draw_boxes(renderer, self.culler.tree.node_bounds[nodes], camera)
        image = renderer.read_rgb()
        if self.show_culled and len(culled_ids):
            # One layer of tint where culled triangles project (stacked translucent layers
            # turned the whole W2 view red).
            image = tint(image, flat_mask(renderer, culled_ids, camera))
        god = None
        if self.god_view:
            boxes = self.culler.tree.node_bounds[nodes] if nodes is not None else None
            levels = None
            if selection is not None:
                levels = (selection.objects, selection.levels,
                          self._lod.selector.boxes[selection.objects])
            god = self._god.draw(self.god_view, camera, culled.triangles, boxes, culled_ids,
                                 levels)
        info = self._info(culled, drawn, cull_ms)
        if at is not None:
            info.update(moving=len(self.animated.motion), pose_ms=pose_ms, time=at,
                        moving_sent=int(culled.stats.get("moving.objects_sent",
                                                         len(self.animated.motion))))
        if selection is not None:
            info.update(lod_tau=self.lod_tau, lod_full=int(len(culled.triangles)),
                        lod_coarse=int((selection.levels > 0).sum()))
        self.last_frame = Frame(image, god, hud_lines(info), info, camera, culled.triangles,
                                dict(culled.stats))
        return self.last_frame

    def _info(self, culled, drawn, cull_ms) -> dict:
        partition = self.partitions.get(self.structure)
        memory = self.profile.estimate_memory(self.world, partition)["total"]
        device_fps = None
        if self._model is not None:
            from ..device.costmodel import device_counters

            stats = device_counters(culled, getattr(self.culler, "tree", None))
            device_fps = 1000.0 / self._model.frame_ms(stats, bool(culled.cull_back))
        return {
            "stages": self.stages, "structure": self.structure, "sent": drawn.triangles,
            "cull_back": bool(culled.cull_back),
            "total": self.world.triangle_count,
            "nodes_visited": int(culled.stats.get("nodes_visited", 0)),
            "cull_ms": cull_ms, "render_ms": drawn.render_ms, "device_fps": device_fps,
            "profile": self.profile.name, "memory_bytes": memory,
            "heap_bytes": self.profile.heap_bytes,
            "frame": self.player.frame if self.mode != "fly" else self.frame,
            "mode": self.mode, "recording": self.recorder.on, "recorded": len(self.recorder),
            "waypoint": self.player.nearest_waypoint() if self.player is not None else None,
            "message": self.message,
        }
