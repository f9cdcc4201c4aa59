"""Device profiles (thesis Table 5.1): screen, index type, vertex format and heap budget.

A profile is the set of limits an OpenGL ES 1.1 device puts on the runtime:
- 16-bit indices, so one draw batch addresses at most 65,535 vertices;
- positions (and normals) as float32 or as GL_FIXED 16.16 (1/65536 units, range +-32767);
- a heap the world, its partition and the GL buffers must fit in.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ProfileError

__all__ = ["Profile", "ProfileError", "PROFILES", "get_profile", "VERTEX_FORMATS",
           "to_fixed", "from_fixed", "FIXED_ONE", "FIXED_LIMIT", "DeviceCost"]

VERTEX_FORMATS = ("float32", "fixed16.16")
FIXED_ONE = 65536            # 1.0 in 16.16
FIXED_LIMIT = 32767.0        # largest |coordinate| the profiles accept in fixed16.16
MAX_INDEX_VERTICES = 65535   # uint16 indices 0..65534 plus one spare (primitive restart value)

# Per-corner vertex layout the renderer uploads (the GL buffers of memory estimates):
# position 3 x 4 bytes (float32 or GL_FIXED), normal 3 x 4 bytes, colour 4 x uint8.
POSITION_BYTES = 12
NORMAL_BYTES = 12
COLOR_BYTES = 4
VERTEX_BYTES = POSITION_BYTES + NORMAL_BYTES + COLOR_BYTES
INDEX_BYTES = 2

MB = 1 << 20


@dataclass(frozen=True)
class DeviceCost:
    """Frame-time figures of one device, priced by vismobile/device/costmodel.py's DeviceModel.

    render ms = render_base_ms + render_triangle_us * triangles_sent / 1000
                + render_call_us * <call_counter> / 1000
    cull ms   = sum of counter x cycles per operation / clock (cycles: costmodel.CULL_OPERATIONS,
                float operations priced at float_op_cycles each)
    clock_mhz       : CPU clock in MHz
    float_op_cycles : cycles of one float add, multiply or compare (emulated on a CPU without FPU)
    call_counter    : the Culler counter that counts the device runtime's draw calls
    source          : where the render figures come from, and how well they fit
    """

    clock_mhz: float
    float_op_cycles: float
    render_base_ms: float
    render_triangle_us: float
    render_call_us: float = 0.0
    call_counter: str = "nodes_drawn"
    source: str = ""


@dataclass(frozen=True)
class Profile:
    """Limits of one device.

    name               : registry key, e.g. "ipaq-hx2490b"
    device, cpu        : Table 5.1 description
    gpu                : True when the device has graphics hardware
    heap_bytes         : int, heap budget the world + partition + buffers must fit in
    resolution         : (width, height) pixels; (240, 320) portrait on the devices
    vertex_format      : "float32" or "fixed16.16"
    index_type         : "uint16" (OpenGL ES 1.1 has no 32-bit indices)
    max_batch_vertices : vertices one draw batch may address (65,535 for uint16)
    cost               : DeviceCost frame-time model, or None: measured on this machine
    max_texture_size   : largest texture side (power of two); the iPaq's software ES 1.1 and
                         the N82's PowerVR MBX Lite are taken as 1024 and 2048 (assumed,
                         not from the thesis)
    """

    name: str
    device: str
    cpu: str
    gpu: bool
    heap_bytes: int
    resolution: tuple = (240, 320)
    vertex_format: str = "float32"
    index_type: str = "uint16"
    max_batch_vertices: int = MAX_INDEX_VERTICES
    cost: DeviceCost | None = None
    max_texture_size: int = 1024

    def __post_init__(self):
        if self.vertex_format not in VERTEX_FORMATS:
            raise ProfileError(f"profile {self.name}: vertex format {self.vertex_format!r} "
                               f"is not one of {', '.join(VERTEX_FORMATS)}")
        if self.index_type != "uint16":
            raise ProfileError(f"profile {self.name}: index type must be uint16 (ES 1.1)")
        if not 3 <= self.max_batch_vertices <= MAX_INDEX_VERTICES:
            raise ProfileError(f"profile {self.name}: max_batch_vertices must be 3.."
                               f"{MAX_INDEX_VERTICES}, got {self.max_batch_vertices}")
        width, height = (int(v) for v in self.resolution)
        if width <= 0 or height <= 0:
            raise ProfileError(f"profile {self.name}: bad resolution {self.resolution}")
        object.__setattr__(self, "resolution", (width, height))

    @property
    def width(self) -> int:
        return self.resolution[0]

    @property
    def height(self) -> int:
        return self.resolution[1]

    @property
    def aspect(self) -> float:
        """Width over height, the camera aspect that fills the screen."""
        return self.width / self.height

    @property
    def batch_triangles(self) -> int:
        """Triangles per draw batch when each triangle owns its three corners."""
        return self.max_batch_vertices // 3

    @property
    def fixed(self) -> bool:
        return self.vertex_format == "fixed16.16"

    @property
    def measured_as(self) -> tuple:
        """What a measurement on this machine depends on: screen, vertex format and batch size.
        Profiles equal here (the iPaq and the N82) cull, render and err identically here; they
        differ only in their device cost models, which every run prices for every device."""
        return self.resolution, self.vertex_format, self.max_batch_vertices

    def with_(self, **changes) -> "Profile":
        """A copy with some fields replaced (e.g. vertex_format="fixed16.16")."""
        return replace(self, **changes)

    def describe(self) -> str:
        gpu = "GPU" if self.gpu else "no GPU"
        return (f"{self.name}: {self.device}, {self.cpu}, {gpu}, heap {self.heap_bytes / MB:g} MB,"
                f" {self.width}x{self.height}, {self.vertex_format}, {self.index_type} indices")

    # ---- vertex formats ---------------------------------------------------------------------
    def vertex_positions(self, positions, what="world") -> np.ndarray:
        """(N, 3) positions as uploaded: float32, or int32 raw 16.16 (range-checked).

        Raises ProfileError naming the largest |coordinate| when fixed16.16 cannot hold it.
        """
        if self.fixed:
            return to_fixed(positions, what)
        return np.ascontiguousarray(positions, dtype=np.float32)

    def check_range(self, positions, what="world") -> None:
        """Raise ProfileError when fixed16.16 cannot hold these positions (no-op for float32)."""
        if self.fixed:
            to_fixed(positions, what)

    # ---- memory ----------------------------------------------------------------------------
    def estimate_memory(self, world, partition=None) -> dict:
        """Bytes the runtime holds for a world (and its partition), by part, plus "total".

        vertex_buffers   : 3 corners per triangle x VERTEX_BYTES (unwelded, one normal each)
        index_buffers    : worst case, every triangle in this frame's uint16 index buffers
        culling_geometry : per-triangle data the culler reads: corners index (3 x int32),
                           normal and box (9 x 4 bytes), and the vertex array (3 x 4 bytes)
        partition        : every array of the partition (nodes, references, extras) as held,
                           level-of-detail chains included (extras lod_*), a PVS not
        pvs              : a baked PVS (extras pvs_*): its arrays as held, its patterns and
                           pattern ids inflated (partition/pvs_codec.py), plus the `pvs`
                           stage's decoded sets (PVS_DECODED combinations of view cells, one
                           byte per triangle each, culling/pvs.py KEEP, plus the fused
                           call's bit per triangle and byte per node, culling/pvs_frame.py)
        textures         : a textured world's (world.textures) mip chains, RGBA8, after the
                           top levels check_memory dropped (texture LOD)
        lod_buffers      : with LOD chains, the level triangles' vertex and index buffers and
                           the selector's tables (a rank per triangle, a stamp per level
                           triangle, 4 bytes each)
        """
        triangles = int(world.triangle_count)
        extras = getattr(partition, "extras", None) or {}
        levels = len(extras["lod_triangles"]) if "lod_triangles" in extras else 0
        parts = {
            "vertex_buffers": 3 * triangles * VERTEX_BYTES,
            "index_buffers": 3 * triangles * INDEX_BYTES,
            "culling_geometry": triangles * (12 + 36) + len(world.vertices) * 12,
            "partition": partition_bytes(partition),
        }
        pvs = {k: v for k, v in extras.items() if k.startswith("pvs_")}
        if pvs:
            parts["partition"] -= sum(np.asarray(v).nbytes for v in pvs.values())
            cells = len(pvs.get("pvs_cells", ()))
            # pvs_shape (partition/pvs_codec.py): layout, V, K patterns, T ids, bytes per id
            shape = np.asarray(pvs.get("pvs_shape", (0,) * 5), dtype=np.int64)
            inflated = int(shape[2]) * ((cells + 7) // 8) + int(shape[3]) * int(shape[4])
            nodes = len(getattr(partition, "first_child", ()))
            decoded = triangles + 8 * (triangles // 64 + 1) + nodes  # per combination
            parts["pvs"] = (sum(np.asarray(v).nbytes for v in pvs.values()) + inflated
                            + min(PVS_DECODED, cells) * decoded)
        textures = getattr(world, "textures", None)
        if textures is not None:
            parts["textures"] = textures.nbytes(self.max_texture_size)
        if levels:
            parts["lod_buffers"] = (3 * levels * (VERTEX_BYTES + INDEX_BYTES)
                                    + 4 * (triangles + levels))
        parts["total"] = sum(parts.values())
        return parts

    def check_memory(self, world, partition=None) -> int:
        """Total bytes of estimate_memory; ProfileError naming both sizes when over the heap.

        A textured world over the heap first loses top mip levels (world.textures.drop, one
        level at a time, down to 1x1 textures): texture LOD under memory pressure."""
        parts = self.estimate_memory(world, partition)
        textures = getattr(world, "textures", None)
        while (textures is not None and parts["total"] > self.heap_bytes
               and textures.drop < textures.levels(self.max_texture_size) - 1):
            textures.drop += 1
            parts = self.estimate_memory(world, partition)
        total = parts["total"]
        if total > self.heap_bytes:
            what = getattr(world, "name", "world")
            if partition is not None:
                what += f" with its {getattr(partition, 'kind', 'partition')} partition"
            raise ProfileError(
                f"{what} needs {total / MB:.1f} MB ({total:,} bytes) but profile {self.name} "
                f"has a {self.heap_bytes / MB:.1f} MB heap ({self.heap_bytes:,} bytes)")
        return total


# Decoded view-cell sets the `pvs` stage keeps (culling/pvs.py KEEP; a test checks they agree).
PVS_DECODED = 64


def partition_bytes(partition) -> int:
    """Bytes of a partition's flat arrays and extras (0 for no partition)."""
    if partition is None:
        return 0
    arrays = [getattr(partition, name) for name in getattr(partition, "ARRAYS", ())]
    arrays += [value for value in getattr(partition, "extras", {}).values()
               if isinstance(value, np.ndarray)]
    return int(sum(np.asarray(a).nbytes for a in arrays))


def to_fixed(values, what="world") -> np.ndarray:
    """float -> int32 16.16 raw values, rounded to nearest: error <= 2^-17 per coordinate.

    Raises ProfileError naming the largest |value| when any lies beyond +-FIXED_LIMIT
    (or is not finite): 16.16 would wrap around, not degrade.
    """
    values = np.asarray(values, dtype=np.float64)
    if values.size:
        largest = float(np.max(np.abs(values)))
        if not np.isfinite(largest) or largest > FIXED_LIMIT:
            raise ProfileError(
                f"{what}: fixed16.16 holds coordinates within +-{FIXED_LIMIT:g} units, but the "
                f"largest |coordinate| is {largest:,.6g} units; use vertex format float32 "
                f"or scale/recentre the world")
    # x * 65536 is exact in float64, so rint is the only rounding.
    return np.rint(values * FIXED_ONE).astype(np.int32)


def from_fixed(raw) -> np.ndarray:
    """int32 16.16 raw -> float64 (exact)."""
    return np.asarray(raw, dtype=np.float64) / FIXED_ONE


# Device cost figures (vismobile/device/costmodel.py explains the model). The render figures are least
# squares (non-negative) of the thesis's own device frame times (study/thesis.DEVICE_POINTS) on
# our counters for the same configurations on our worlds (costmodel.CALIBRATION_ROWS); the
# per-call term is kept only where it lowers the leave-one-out error. The cull figures are
# estimates: clock from Table 5.1, float cost from the CPU (PXA270: no FPU, software float;
# ARM11: VFP11 hardware float).
IPAQ_COST = DeviceCost(
    clock_mhz=520.0, float_op_cycles=50.0, render_base_ms=89.60, render_triangle_us=18.648,
    render_call_us=149.84, call_counter="nodes_drawn",
    source="fitted to 7 iPaq means (6 per-world bests, W1 without culling = 114.6 / 0.59 ms): "
           "mean error 17%, leave-one-out 27% (worst 52%); triangles alone: 41% "
           "leave-one-out. Not reproduced: W2 with the grid (0.49 fps = 2041 ms) is predicted "
           "at 337 ms, as our grid sends about as many triangles as the octree")
N82_COST = DeviceCost(
    clock_mhz=332.0, float_op_cycles=4.0, render_base_ms=31.85, render_triangle_us=8.057,
    render_call_us=0.0, call_counter="nodes_drawn",
    source="fitted to the 6 N82 means (1000 / fps, the iPaq's best configuration assumed): "
           "mean error 18%, leave-one-out 27% (worst 48%); a per-call term does not lower "
           "the held-out error (30%)")

PROFILES = {
    profile.name: profile for profile in (
        Profile("ipaq-hx2490b", "HP iPaq hx2490b (Windows Mobile 5)", "520 MHz Intel PXA270",
                gpu=False, heap_bytes=64 * MB, cost=IPAQ_COST),
        Profile("nokia-n82", "Nokia N82 (Symbian S60)", "332 MHz ARM11",
                gpu=True, heap_bytes=128 * MB, cost=N82_COST, max_texture_size=2048),
        Profile("desktop", "desktop reference", "x86-64", gpu=True, heap_bytes=4096 * MB,
                resolution=(640, 480), max_texture_size=8192),
    )
}


def get_profile(name, vertex_format=None) -> Profile:
    """The profile registered under name, optionally with another vertex format."""
    if isinstance(name, Profile):
        profile = name
    else:
        try:
            profile = PROFILES[name]
        except KeyError:
            raise ProfileError(f"unknown profile {name!r}; known: {', '.join(PROFILES)}") from None
    if vertex_format is not None and vertex_format != profile.vertex_format:
        profile = profile.with_(vertex_format=vertex_format)
    return profile
