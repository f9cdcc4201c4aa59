"""The viewer on a terrain (.vmt): a flythrough of app/terrain_scene.py's frames.

The window, joystick, recorder, playback and god view are the Session's; what differs: each
frame is the terrain's LOD method at tau plus its objects culled (TerrainScene.frame), T
cycles tau (TERRAIN_TAUS), M cycles the method (tiles, roettger, roam: each built once and kept
with its frame-to-frame state), the number keys and H toggle the objects' culling stages. The
god view draws a coarse stand-in of the ground (at most 2 * 64^2 triangles) and the objects.
"""
from __future__ import annotations

import time

import numpy as np

from ..app.playback import Scene
from ..app.terrain_scene import METHODS, TerrainScene
from ..errors import VisMobileError
from ..world.camera import Camera
from .hud import MB
from .session import Frame, Session

TERRAIN_TAUS = (0.5, 1.0, 2.0, 4.0, 8.0)  # T cycles these (pixels)
STAND_IN_CELLS = 64  # cells per side of the god view's ground


def stand_in(heightmap, placement):
    """The ground every stride samples (at most STAND_IN_CELLS cells a side) plus the
    objects, as a World: what the god view outlines and the joystick's speeds scale to."""
    from ..terrain.mesh import terrain_world

    stride = max(1, (heightmap.size - 1) // STAND_IN_CELLS)
    return terrain_world(heightmap, placement if len(placement) else None, stride)


class TerrainSession(Session):
    """A Session whose frames are a TerrainScene's (module doc)."""

    def __init__(self, terrain: TerrainScene, trajectory=None, record_path="recorded.csv",
                 **options):
        from ..app.terrain_play import terrain_camera_options

        self.terrain = terrain
        paged = getattr(terrain.lod, "paged", None)  # a .vmtiles or .vmrpages terrain
        world = stand_in(terrain.heightmap if paged is None else paged.coarse_heightmap(),
                         terrain.placement)
        super().__init__(Scene(world, None, "none"), (), terrain.profile, trajectory,
                         record_path, structures=("none",), start="overview", **options)
        self.structure = terrain.structure
        self.stages = terrain.stages
        self.lod_tau = terrain.tau
        self.options = terrain_camera_options(terrain.heightmap)
        if trajectory is None:  # the fast circle path's first pose
            from ..app.terrain_scene import default_cameras

            first = default_cameras(terrain.heightmap, 1, terrain.profile.aspect)[0]
            self.pose = np.array([*first.position, first.yaw, first.pitch])

    @classmethod
    def open_terrain(cls, path, method=None, tau=1.0, stages=("vfc", "horizon"),
                     structure="octree:4", profile="ipaq-hx2490b", trajectory=None,
                     object_lod: bool = False, cache_dir=None, **options) -> "TerrainSession":
        """object_lod: the objects at their coarsest level of detail within the terrain's tau
        (TerrainScene's; T changes both)."""
        return cls(TerrainScene(path, method, tau, stages, structure, profile,
                                object_lod=object_lod, cache_dir=cache_dir), trajectory,
                   **options)

    def camera(self):
        """The current pose with the terrain's field of view, near and far planes."""
        x, y, z, yaw, pitch = (self.player.trajectory.poses[self.player.frame]
                               if self.mode != "fly" else self.pose)
        return Camera((x, y, z), yaw, pitch, aspect=self.profile.aspect, **self.options)

    def set_view_size(self, width: int, height: int) -> None:
        """The terrain's renderers are built for the profile's screen: it stays that size
        (a desktop window shows it as it is)."""
        if self.profile.name == "desktop" and (width, height) != self.profile.resolution:
            self.message = "a terrain view keeps the profile's screen size"

    def press(self, action: str) -> None:
        terrain = self.terrain
        if action == "lod_tau":
            index = TERRAIN_TAUS.index(terrain.tau) if terrain.tau in TERRAIN_TAUS else -1
            terrain.tau = TERRAIN_TAUS[(index + 1) % len(TERRAIN_TAUS)]
            self.lod_tau = terrain.tau
            self.message = f"terrain tau {terrain.tau:g} px"
        elif action == "terrain_method":
            method = METHODS[(METHODS.index(terrain.method) + 1) % len(METHODS)]
            try:
                terrain.set_method(method)
            except VisMobileError as error:  # a paged terrain has one method
                self.message = str(error)
                return
            self.message = f"terrain method {method}"
        elif action.startswith("toggle:"):
            stage = action.split(":", 1)[1]
            stages = tuple(s for s in self.stages if s != stage) if stage in self.stages \
                else self.stages + (stage,)
            try:
                terrain.set_stages(stages)
            except VisMobileError as error:
                self.message = str(error)
                return
            self.stages = stages
            self.message = f"{stage} {'on' if stage in stages else 'off'}"
        elif action == "next_structure":
            self.message = f"the objects' structure stays {terrain.structure} on a terrain"
        elif action in ("show_culled", "show_nodes"):
            self.message = "not drawn on a terrain view"
        else:
            super().press(action)

    def render(self) -> Frame:
        """One TerrainScene frame; HUD and god view added (not timed)."""
        camera = self.camera()
        start = time.perf_counter()
        f = self.terrain.frame(camera)
        frame_ms = (time.perf_counter() - start) * 1000.0
        image = self.terrain.read_rgb()
        culled = self.terrain.culled
        sent = culled.triangles if culled is not None else np.zeros(0, np.int64)
        god = None
        if self.god_view:
            # The stand-in holds the ground first, then the objects in the same order.
            ground = self.world.triangle_count - (self.terrain.objects.triangle_count
                                                  if self.terrain.objects is not None else 0)
            god = self._god.draw(self.god_view, camera, sent + ground)
        t = self.terrain
        lines = [
            f"{t.method} at tau {t.tau:g} px   (M method, T tau)",
            f"ground {f.ground_triangles:,} tris  bound {f.error_px:.2f} px",
            f"objects {f.object_triangles:,} tris{' at LOD' if t.object_lod else ''}  "
            f"{'+'.join(self.stages) or 'no culling'} / {t.structure}",
            f"horizon hid {f.nodes_hidden} nodes, {f.triangles_hidden:,} tris",
            f"LOD {f.lod_ms:.2f} cull {f.cull_ms:.2f} render {f.render_ms:.2f} ms "
            f"({1000.0 / max(frame_ms, 1e-9):.0f} fps here)",
            f"frame {self.player.frame if self.mode != 'fly' else self.frame}  {self.mode}"
            + (f"  REC {len(self.recorder)}" if self.recorder.on else ""),
        ]
        if self.message:
            lines.append(self.message)
        info = {"stages": self.stages, "structure": t.structure, "sent": f.triangles,
                "cull_back": False, "method": t.method, "tau": t.tau, "error_px": f.error_px,
                "ground_triangles": f.ground_triangles, "object_triangles": f.object_triangles,
                "render_ms": f.render_ms, "cull_ms": f.cull_ms, "lod_ms": f.lod_ms,
                "memory_mb": self.profile.estimate_memory(self.world, None)["total"] / MB}
        self.last_frame = Frame(image, god, lines, info, camera, sent, dict(f.stats))
        return self.last_frame
