"""Base-colour textures of a scene: per-corner UVs, one image per object, and mip chains.

A glTF/GLB material's baseColorTexture, or an OBJ's MTL map_Kd, read through trimesh. Images
are resized to power-of-two sides no larger than the device's maximum texture size (OpenGL
ES 1.1 needs both) and given a full mip chain (2x2 box filter), which is what the heap holds;
under memory pressure the top `drop` levels are left out (texture LOD: each level dropped
divides the texture's bytes by about four).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import WorldError

BYTES_PER_TEXEL = 4  # RGBA8


@dataclass(eq=False)
class Textures:
    """uv         : (T, 3, 2) float32 texture coordinates per triangle corner (0 untextured)
    texture_of : (O,) int32 image index per object, -1 for an untextured object
    images     : list of (H, W, 4) uint8 RGBA images as read, row 0 = top
    drop       : top mip levels left out (set by Profile.check_memory under memory pressure)
    """

    uv: np.ndarray
    texture_of: np.ndarray
    images: list = field(default_factory=list)
    drop: int = 0

    def chain(self, index: int, max_size: int, drop: int | None = None) -> list:
        """Mip levels of image `index`, largest first, after dropping the top `drop` levels
        (default self.drop; the 1x1 level is always kept): each (h, w, 4) uint8."""
        levels = mip_chain(self.images[index], max_size)
        drop = self.drop if drop is None else drop
        return levels[min(drop, len(levels) - 1):]

    def nbytes(self, max_size: int, drop: int | None = None) -> int:
        """Bytes of every image's mip chain as the device holds it (RGBA8)."""
        total = 0
        drop = self.drop if drop is None else drop
        for image in self.images:
            h, w = pot_size(image.shape[:2], max_size)
            for level in range(drop, 64):
                lh, lw = max(h >> level, 1), max(w >> level, 1)
                total += lh * lw * BYTES_PER_TEXEL
                if lh == 1 and lw == 1:
                    break
        return total

    def levels(self, max_size: int) -> int:
        """Mip levels of the largest image (how many a drop can remove, minus one)."""
        sizes = [max(pot_size(i.shape[:2], max_size)) for i in self.images] or [1]
        return int(max(sizes)).bit_length()


def pot_size(shape, max_size: int) -> tuple:
    """(h, w): each side rounded to the nearest power of two, at most max_size, at least 1."""
    out = []
    for side in shape[:2]:
        p = 1 << max(int(round(np.log2(max(int(side), 1)))), 0)
        out.append(int(min(p, max_size)))
    return tuple(out)


def mip_chain(image, max_size: int) -> list:
    """Full mip chain of an RGBA image: resized to pot_size (PIL, box filter), then halved by
    2x2 averages down to 1x1. Returns [(h, w, 4) uint8, ...], largest first."""
    from PIL import Image

    h, w = pot_size(image.shape[:2], max_size)
    base = np.asarray(Image.fromarray(np.ascontiguousarray(image, np.uint8)).resize(
        (w, h), Image.BOX), dtype=np.uint8)
    levels = [base]
    while levels[-1].shape[0] > 1 or levels[-1].shape[1] > 1:
        a = levels[-1].astype(np.uint32)
        if a.shape[0] > 1:
            a = a[0::2] + a[1::2]
        else:
            a = a * 2
        if a.shape[1] > 1:
            a = a[:, 0::2] + a[:, 1::2]
        else:
            a = a * 2
        levels.append(((a + 2) // 4).astype(np.uint8))
    return levels


def read_textures(path, world) -> Textures | None:
    """Textures of a glTF/GLB or OBJ(+MTL) file for `world` (World.from_file of the same
    path: same objects, in the same node order, after the same triangle drops), or None when
    no object has a base-colour texture with UVs. Raises WorldError naming the file when the
    texture data does not match the geometry."""
    import trimesh

    from ..files.meshfile import flatten

    path = Path(path)
    try:
        scene = trimesh.load(str(path), force="scene")
    except Exception as error:  # trimesh raises many kinds on bad files
        raise WorldError(path, f"cannot read textures: {error}") from None
    parts = []
    for node in sorted(scene.graph.nodes_geometry, key=str):
        transform, name = scene.graph[node]
        mesh = scene.geometry.get(name)
        if isinstance(mesh, trimesh.Trimesh) and len(mesh.faces):
            parts.append((mesh, np.linalg.det(np.asarray(transform, float)[:3, :3]) < 0))
    images, uv_parts, texture_of = [], [], []
    for mesh, flip in parts:
        image, uv = _base_color(mesh)
        faces = np.asarray(mesh.faces, np.int64)
        if flip:
            faces = faces[:, ::-1]
        if image is None:
            uv_parts.append(np.zeros((len(faces), 3, 2), np.float32))
            texture_of.append(-1)
            continue
        if uv.shape != (len(mesh.vertices), 2) or not np.isfinite(uv).all():
            raise WorldError(path, "texture coordinates do not match the mesh's vertices")
        uv_parts.append(uv[faces].astype(np.float32))
        texture_of.append(len(images))
        images.append(image)
    if not images:
        return None
    uv = np.concatenate(uv_parts)
    vertices, triangles, ids, names = flatten(scene, str(path))
    kept = kept_triangles(vertices, triangles, ids, names)
    if len(uv) != len(triangles) or len(kept) != world.triangle_count:
        raise WorldError(path, "texture coordinates do not match the world's triangles")
    return Textures(np.ascontiguousarray(uv[kept]), np.asarray(texture_of, np.int32), images)


def kept_triangles(vertices, triangles, ids, names) -> np.ndarray:
    """(k,) int64 indices of the triangles World.from_arrays keeps (not zero-area, first copy)."""
    from .world import ZERO_AREA_RELATIVE, World, _repeated

    world = World(vertices, triangles, ids, list(names))
    scale = float(np.ptp(world.extent, axis=0).max()) if world.triangle_count else 0.0
    size = max(scale, 1e-300)
    with np.errstate(over="ignore", invalid="ignore"):
        keep = world.areas * 2.0 / size / size > ZERO_AREA_RELATIVE
    return np.flatnonzero(keep & ~(_repeated(world.triangles) & keep))


def _base_color(mesh):
    """(RGBA image (h, w, 4) uint8 row 0 = top, or None; per-vertex UVs (V, 2) as trimesh
    gives them, v = 0 at the image's bottom row as in OpenGL) of a mesh's base colour."""
    visual = mesh.visual
    if getattr(visual, "kind", None) != "texture" or getattr(visual, "uv", None) is None:
        return None, None
    material = visual.material
    image = getattr(material, "baseColorTexture", None)
    if image is None:
        image = getattr(material, "image", None)
    if image is None:
        return None, None
    rgba = np.asarray(image.convert("RGBA"), dtype=np.uint8)
    uv = np.asarray(visual.uv, dtype=np.float64).copy()
    return rgba, uv


def read_obj_textures(path, world) -> Textures | None:
    """Textures of an OBJ whose MTL gives map_Kd images, for `world` (World.from_obj of the
    same file), or None when it has none. The OBJ is read again through trimesh with its
    materials (same validated text, same object split, the MTL and images beside the file);
    when its triangles do not come out as the world's (same corners, same order), the world
    stays untextured with a warning: a limit of this reader, not bad input."""
    import io
    import warnings

    import trimesh

    from ..files.obj import read_text, validate_obj

    path = Path(path)
    text = validate_obj(path, read_text(path))
    try:
        stream = io.BytesIO(text.encode("utf-8"))
        stream.name = path.name
        scene = trimesh.load(stream, file_type="obj", force="scene", split_objects=True,
                             split_groups=True, group_material=False, process=True,
                             skip_materials=False,
                             resolver=trimesh.resolvers.FilePathResolver(str(path.parent)))
    except Exception as error:  # trimesh raises many kinds on bad material files
        warnings.warn(f"{path}: textures not read ({type(error).__name__}: {error})",
                      stacklevel=2)
        return None
    meshes = sorted(((str(n), g) for n, g in scene.geometry.items()
                     if isinstance(g, trimesh.Trimesh) and len(g.faces)), key=lambda m: m[0])
    images, uv_parts, corners, texture_of = [], [], [], []
    for _, mesh in meshes:
        faces = np.asarray(mesh.faces, np.int64)
        corners.append(np.asarray(mesh.vertices, float)[faces])
        image, uv = _base_color(mesh)
        if image is None or uv is None or len(uv) != len(mesh.vertices):
            uv_parts.append(np.zeros((len(faces), 3, 2), np.float32))
            texture_of.append(-1)
            continue
        uv_parts.append(uv[faces].astype(np.float32))
        texture_of.append(len(images))
        images.append(image)
    if not images:
        return None
    corners = np.concatenate(corners)
    uv = np.concatenate(uv_parts)
    ids = np.repeat(np.arange(len(meshes)), [len(m.faces) for _, m in meshes])
    triangles = np.arange(3 * len(corners)).reshape(-1, 3)
    kept = kept_triangles(corners.reshape(-1, 3), triangles, ids, [n for n, _ in meshes])
    if (len(meshes) != len(world.object_names) or len(kept) != world.triangle_count
            or not np.allclose(corners[kept], world.corners, rtol=0, atol=1e-9)):
        warnings.warn(f"{path}: its textured triangles do not match the world's; drawn "
                      "untextured", stacklevel=2)
        return None
    return Textures(np.ascontiguousarray(uv[kept]), np.asarray(texture_of, np.int32), images)


def _names_mtllib(path, chunk=1 << 20) -> bool:
    """True when the file holds b"mtllib" (read in pieces: bounded memory)."""
    tail = b""
    with open(path, "rb") as handle:
        while True:
            data = handle.read(chunk)
            if not data:
                return False
            if b"mtllib" in tail + data:
                return True
            tail = data[-5:]


def textured_world(path):
    """World.from_file(path) with `.textures` set (Textures or None): glTF/GLB base-colour
    textures, or an OBJ's MTL map_Kd (only read when the OBJ names an mtllib)."""
    from .world import World

    path = Path(path)
    world = World.from_file(path)
    if path.suffix.lower() == ".obj":
        world.textures = read_obj_textures(path, world) if _names_mtllib(path) else None
    else:
        world.textures = read_textures(path, world)
    return world
