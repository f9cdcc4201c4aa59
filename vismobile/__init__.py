"""vismobile: spatial partitions and visibility culling for OpenGL ES 1.1-class hardware.

The pipeline, one package per stage, data flowing one way:
world -> partition/ -> culling/ -> render/ -> study/
"""
from importlib import import_module

__version__ = "0.1.0"
VERSION = __version__  # the old name, kept for scripts that read it

# Public names, imported on first use so that `import vismobile` stays light.
_EXPORTS = {
    "World": "vismobile.world",
    "Camera": "vismobile.camera",
    "Trajectory": "vismobile.trajectory",
    "build_world": "vismobile.scenes",
    "VisMobileError": "vismobile.errors",
    "WorldError": "vismobile.errors",
    "PartitionError": "vismobile.errors",
    "ProfileError": "vismobile.errors",
    "TrajectoryError": "vismobile.errors",
    "Partition": "vismobile.partition.base",
    "partition": "vismobile.partition",
    "load_partition": "vismobile.partition",
    "Culler": "vismobile.culling",
    "Profile": "vismobile.profile",
    "AdaptiveCuller": "vismobile.culling.adaptive",
    "tune": "vismobile.study.tune",
    "get_profile": "vismobile.profile",
    "PROFILES": "vismobile.profile",
    "STAGES": "vismobile.culling",
    "render_rgb": "vismobile.render",
    "item_buffer": "vismobile.render",
    "Renderer": "vismobile.render",
    "open_world": "vismobile.scenes",
    "load_scene": "vismobile.playback",
    "play": "vismobile.playback",
    "Scene": "vismobile.playback",
    "parse_spec": "vismobile.partition.spec",
    "format_spec": "vismobile.partition.spec",
    "check_winding": "vismobile.winding",
    "fixed_world": "vismobile.winding",
    "generate_trajectory": "vismobile.walk",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'vismobile' has no attribute {name!r}")
