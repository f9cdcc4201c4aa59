"""vismobile: spatial partitions and visibility culling for OpenGL ES 1.1-class hardware.

The pipeline, one package per stage, data flowing one way:
world -> partition/ -> culling/ -> render/ -> study/

    import vismobile
    from vismobile import World, Camera, Culler, partition, get_profile, render_rgb

    world = vismobile.load_world("room.glb")       # or build_world("w2"), open_world("w2")
    tree = partition(world, "octree:4")            # the CLI's grammar, or ("octree", depth=4)
    camera = Camera((0.0, 1.6, 3.0), yaw=0.0, pitch=-5.0)
    result = Culler(tree, "vfc+bfc").cull(camera)  # result.triangles: the ids to draw
    image = render_rgb(world, result.triangles, camera, get_profile("desktop"), result.cull_back)

Public names (imported on first use; each has its own help()):
  worlds      World, load_world, build_world, open_world, check_winding, fixed_world, Trajectory,
              generate_trajectory, Camera
  partitions  partition, load_partition, save_partition, Partition, parse_spec, format_spec
  culling     Culler, STAGES, AdaptiveCuller
  devices     Profile, get_profile, PROFILES
  rendering   render_rgb, item_buffer, Renderer
  playback    load_scene, play, Scene
  study       tune
  errors      VisMobileError, WorldError, PartitionError, ProfileError, TrajectoryError
"""
import sys
import types
from importlib import import_module

__version__ = "0.1.0"


def _kernel_cache_dir() -> None:
    """Give numba's on-disk cache one folder per content of the package's sources.

    numba checks a cached kernel against its own file's timestamp only, so a kernel that
    inlines a callee from another file kept the old callee after that file changed (seen when
    hiz/buffer.py changed under occlusion_chain's cached frame): after an edit or an upgrade a
    stale, possibly no longer conservative, kernel would run. Hashing the sources (about 7 ms)
    makes any change start a fresh folder; folders unused for a week are removed. Under the
    user's NUMBA_CACHE_DIR when set, else ~/.cache/vismobile/numba; numba's defaults stay if
    the folder cannot be made."""
    import hashlib
    import os
    import shutil
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parent
    digest = hashlib.sha1()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    try:  # no home folder, or none writable: numba's defaults
        base = Path(os.environ.get("NUMBA_CACHE_DIR")
                    or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
                    / "vismobile" / "numba")
        if base.name.startswith("vismobile-"):  # chosen by this function (a child process)
            base = base.parent
        folder = base / f"vismobile-{digest.hexdigest()[:16]}"
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)
    except (OSError, RuntimeError):
        return
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:  # numba read its configuration already
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    week = time.time() - 7 * 86400
    for old in base.glob("vismobile-*"):
        try:
            if old != folder and old.stat().st_mtime < week:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:
            pass


_kernel_cache_dir()
VERSION = __version__  # the old name, kept for scripts that read it

# Public names, imported on first use so that `import vismobile` stays light.
_EXPORTS = {
    "World": "vismobile.world.world",
    "Camera": "vismobile.world.camera",
    "Trajectory": "vismobile.world.trajectory",
    "build_world": "vismobile.scenes",
    "VisMobileError": "vismobile.errors",
    "WorldError": "vismobile.errors",
    "PartitionError": "vismobile.errors",
    "ProfileError": "vismobile.errors",
    "TrajectoryError": "vismobile.errors",
    "Partition": "vismobile.partition.base",
    "partition": "vismobile.partition",
    "load_partition": "vismobile.partition",
    "save_partition": "vismobile.partition",
    "Culler": "vismobile.culling",
    "Profile": "vismobile.device.profile",
    "AdaptiveCuller": "vismobile.culling.adaptive",
    "tune": "vismobile.study.tune",
    "get_profile": "vismobile.device.profile",
    "PROFILES": "vismobile.device.profile",
    "STAGES": "vismobile.culling",
    "render_rgb": "vismobile.render",
    "item_buffer": "vismobile.render",
    "Renderer": "vismobile.render",
    "open_world": "vismobile.files.loader",
    "load_world": "vismobile.files.loader",
    "load_scene": "vismobile.app.playback",
    "play": "vismobile.app.playback",
    "Scene": "vismobile.app.playback",
    "parse_spec": "vismobile.partition.spec",
    "format_spec": "vismobile.partition.spec",
    "check_winding": "vismobile.world.winding",
    "fixed_world": "vismobile.world.winding",
    "generate_trajectory": "vismobile.app.walk",
}

__all__ = sorted(_EXPORTS)


class _LazyModule(types.ModuleType):
    """The package module, resolving the public names on first use. A module class rather
    than a module-level __getattr__, so that help(vismobile) lists the public classes and
    functions (dir() gives them) and no __getattr__ among them."""

    def __getattr__(self, name):
        if name in _EXPORTS:
            value = getattr(import_module(_EXPORTS[name]), name)
            return value
        raise AttributeError(f"module 'vismobile' has no attribute {name!r}")

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(__all__))


sys.modules[__name__].__class__ = _LazyModule
