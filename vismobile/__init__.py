"""vismobile: spatial partitions and visibility culling for OpenGL ES 1.1-class hardware.

The pipeline, one package per stage, data flowing one way:
world -> partition/ -> culling/ -> render/ -> study/
"""
from importlib import import_module

VERSION = "0.1.0"

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
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'vismobile' has no attribute {name!r}")
