"""The one place open3d is imported: lazily, after loading the libusb its wheels link against."""
from __future__ import annotations

import ctypes
import functools


@functools.lru_cache(maxsize=1)
def open3d():
    """Return the open3d module; fresh machines lack libusb-1.0, so load PyPI's copy first."""
    try:
        ctypes.CDLL("libusb-1.0.so.0", mode=ctypes.RTLD_GLOBAL)
    except OSError:
        import libusb_package

        path = libusb_package.get_library_path()
        if path is None:
            raise ImportError("libusb-1.0 not found: install libusb-package or libusb-1.0-0")
        ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)
    import open3d as o3d

    return o3d


def decimate(vertices, triangles, target_count: int):
    """Quadric decimation (open3d) to at most target_count triangles: (vertices, triangles)."""
    import numpy as np

    o3d = open3d()
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.asarray(vertices, float)),
                                     o3d.utility.Vector3iVector(np.asarray(triangles, np.int32)))
    simple = mesh.simplify_quadric_decimation(target_number_of_triangles=int(target_count))
    simple.remove_degenerate_triangles()
    simple.remove_unreferenced_vertices()
    return np.asarray(simple.vertices), np.asarray(simple.triangles, dtype=np.int32)


def raycast_primitive_ids(vertices, triangles, origins, directions):
    """Embree ray casting (open3d RaycastingScene): (R,) int64 first-hit triangle id, -1 on miss."""
    import numpy as np

    o3d = open3d()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(vertices, np.float32)),
                        o3d.core.Tensor(np.asarray(triangles, np.uint32)))
    rays = np.concatenate([origins, directions], axis=1).astype(np.float32)
    hits = scene.cast_rays(o3d.core.Tensor(rays))
    ids = hits["primitive_ids"].numpy().astype(np.int64)
    ids[~np.isfinite(hits["t_hit"].numpy())] = -1
    return ids
