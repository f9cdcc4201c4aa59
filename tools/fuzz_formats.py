"""Fuzz targets of mesh, scene and terrain files (tools/fuzz.py imports them): PLY, STL, OFF,
GLB and gzip-compressed meshes, .vmt terrains and .npy heightmaps (issue 28); textured GLB and
OBJ+MTL scenes (glb, objmtl: issue 27); GeoTIFF heightmaps, .vmt terrains as `play` runs them
(vmtplay) and .vmtiles paged terrains (issue 30): their seeds (format_seeds, which also holds
fuzz_motion's, fuzz_tiled's and fuzz_repair's) and entry points. Each entry loads or ends in a
VisMobileError."""
from __future__ import annotations

from pathlib import Path

import fuzz_motion
import fuzz_repair
import fuzz_tiled


def vmtiles_seed(heightmap, folder, name="seed") -> bytes:
    """A .vmtiles file of a small terrain (terrain tile; issue 30's paged terrains; with
    no-data samples: the holes flag and the no-data normal bytes)."""
    from vismobile.terrain.paged import write_tiles
    from vismobile.terrain.tiles import TilePyramid

    write_tiles(TilePyramid.build(heightmap, 4), folder / f"{name}.vmtiles")
    return (folder / f"{name}.vmtiles").read_bytes()


def format_seeds(world, folder: Path, glbs=()) -> dict:
    """Seeds of the issue 28 surfaces: the model as PLY (ASCII, both binary byte orders), STL
    (binary, ASCII), OFF and GLB (one node, and two nodes with transforms), a .gz PLY, a small
    .vmt terrain with objects, .npy heightmaps; and an OBJ naming an MTL with a map_Kd image
    (issue 27); and the seeds of fuzz_motion's, fuzz_tiled's and fuzz_repair's targets. glbs: GLB seeds put
    first (the textured one)."""
    import gzip
    import io

    import numpy as np
    import trimesh

    import hostile_writers as hostile
    from vismobile.terrain import sources, store
    from vismobile.terrain.heightmap import quantize
    from vismobile.terrain.placement import place_objects

    mesh = trimesh.Trimesh(world.vertices, world.triangles, process=False)
    v, f = mesh.vertices.tolist(), mesh.faces.tolist()
    plys = [hostile.ply(v, f, fmt) for fmt in ("ascii", "binary_little_endian",
                                               "binary_big_endian")]
    doc, binary = hostile.gltf(v, f)
    nodes = [{"children": [1], "matrix": [2, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 3, 4, 5, 1]},
             {"mesh": 0, "translation": [1, 2, 3], "scale": [1, -1, 1]}]
    two, _ = hostile.gltf(v, f, nodes=nodes)
    heightmap = sources.diamond_square(17, seed=1)
    store.save(folder / "seed.vmt", heightmap, place_objects(heightmap, 3, 1, 2.0))
    holed = heightmap.heights.astype(np.float64)
    holed[5:9, 3:12] = np.nan  # no data: a version 2 .vmt with its mask section (issue 30)
    store.save(folder / "holes.vmt", quantize(holed, 1.0, "holes"))
    arrays = []
    tifs = []
    for array, predictor in ((heightmap.heights.astype(np.float32), 3),
                             (np.arange(-40, 40, dtype=np.int16).reshape(8, 10), 2)):
        from PIL import Image, TiffImagePlugin

        info = TiffImagePlugin.ImageFileDirectory_v2()
        info[42113], info.tagtype[42113] = "-9999", 2  # GDAL_NODATA (issue 30's GeoTIFFs)
        info[33550], info.tagtype[33550] = (30.0, 30.0, 0.0), 12  # ModelPixelScaleTag
        info[317] = predictor
        buffer = io.BytesIO()
        Image.fromarray(array).save(buffer, format="TIFF", compression="tiff_adobe_deflate",
                                    tiffinfo=info)
        tifs.append(buffer.getvalue())
    for array in (heightmap.heights, np.arange(12, dtype=np.uint16).reshape(3, 4), holed):
        buffer = io.BytesIO()
        np.save(buffer, array)
        arrays.append(buffer.getvalue())
    return {"ply": plys, "stl": [mesh.export(file_type="stl"),
                                 mesh.export(file_type="stl_ascii").encode()],
            "off": [hostile.off(v, f)],
            "objmtl": [TEXTURED_OBJ],
            "glb": [*glbs, hostile.glb(doc, binary), hostile.glb(two, binary)],
            "gz": [gzip.compress(plys[1])], "vmt": [(folder / "seed.vmt").read_bytes(),
                                                    (folder / "holes.vmt").read_bytes()],
            "vmtplay": [(folder / "seed.vmt").read_bytes()],
            "npy": arrays, "tif": tifs,
            "vmtiles": [vmtiles_seed(heightmap, folder),
                        vmtiles_seed(quantize(holed, 1.0, "holes"), folder, "holes")],
            **fuzz_motion.animated_seeds(folder), **fuzz_tiled.tiled_seeds(folder),
            **fuzz_tiled.pages_seeds(folder), **fuzz_repair.repair_seeds()}


def load_textured(path):
    """A textured GLB: the world, its base-colour textures and UVs (issue 27), drawn once."""
    import numpy as np

    from vismobile.device.profile import get_profile
    from vismobile.files.loader import load_world
    from vismobile.render.textured import renderer_for
    from vismobile.world.camera import Camera

    world = load_world(path)
    profile = get_profile("ipaq-hx2490b")
    profile.check_memory(world)
    low, high = world.extent
    renderer_for(world, profile).draw(np.arange(world.triangle_count),
                                      Camera(tuple(high + (high - low) + 1.0), 45.0, -30.0))


TEXTURED_OBJ = (b"mtllib quad.mtl\no a_quad\nv -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\n"
                b"vt 0 0\nvt 8 0\nvt 8 8\nvt 0 8\nusemtl checker\nf 1/1 2/2 3/3\n"
                b"f 1/1 3/3 4/4\no b_plain\nv 0 0 1\nv 0.5 0 1\nv 0 0.5 1\nvt 0 0\n"
                b"usemtl plain\nf 5/5 6/5 7/5\n")


def load_textured_obj(path):
    """An OBJ naming an MTL with a map_Kd image (both written beside it): world, textures,
    one textured draw (issue 27)."""
    import numpy as np
    from PIL import Image

    folder = Path(path).parent
    if not (folder / "quad.mtl").exists():
        (folder / "quad.mtl").write_text("newmtl checker\nKd 1 1 1\nmap_Kd checker.png\n"
                                         "newmtl plain\nKd 0.5 0.5 0.5\n")
        rows, cols = np.indices((24, 40)) // 4
        image = np.where(((rows + cols) % 2 == 0)[..., None], (230, 30, 30), (30, 30, 230))
        Image.fromarray(image.astype(np.uint8)).save(folder / "checker.png")
    load_textured(path)


def textured_glb() -> bytes:
    """A quad with a checker base-colour texture and an untextured box, as GLB bytes."""
    import numpy as np
    import trimesh
    from PIL import Image

    quad = trimesh.Trimesh([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    rows, cols = np.indices((24, 40)) // 4
    image = np.where(((rows + cols) % 2 == 0)[..., None], (230, 30, 30), (30, 30, 230))
    material = trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(image.astype(np.uint8)))
    quad.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [8, 0], [8, 8], [0, 8]],
                                                material=material)
    scene = trimesh.Scene()
    scene.add_geometry(quad, node_name="a_quad", geom_name="quad")
    scene.add_geometry(trimesh.creation.box(extents=(0.5, 0.5, 0.5)), node_name="b_box")
    return scene.export(file_type="glb")


def load_mesh(path):
    from vismobile.world.world import World

    World.from_file(path)


def load_vmt(path):
    from vismobile.files.loader import load_world

    load_world(path)  # the terrain's ground and objects as a World


def load_vmt_play(path):
    """A .vmt as `play` runs it (issue 30): its LOD method (ROAM), its objects partitioned and
    culled by vfc+horizon over the heightmap, one frame drawn."""
    from vismobile.app.terrain_scene import TerrainScene, default_cameras

    scene = TerrainScene(path, "roam", 1.0, ("vfc", "horizon"), "octree:2")
    scene.frame(default_cameras(scene.heightmap, 1, scene.profile.aspect)[0])


def load_vmtiles(path):
    """A .vmtiles terrain paged in by tiles (issue 30): opened, every record read, a frame
    selected and its tiles drawn from the page cache."""
    import numpy as np

    from vismobile.device.profile import get_profile
    from vismobile.render.tile_arena import PagedArena
    from vismobile.terrain.paged import PagedTiles
    from vismobile.terrain.tiles import select_tiles
    from vismobile.world.camera import Camera

    paged = PagedTiles(path, budget_bytes=4096, thread=False)
    try:
        for tile in range(int(paged.offsets[-1])):
            paged._read(tile)
        hm = paged.heightmap
        camera = Camera((hm.extent / 2, hm.high + hm.extent, hm.extent * 1.2), 0.0, -40.0,
                        fov=60, far=10 * hm.extent + 10, near=0.01 * hm.extent + 1e-3)
        profile = get_profile("ipaq-hx2490b")
        selection = select_tiles(paged.pyramid, camera, profile.resolution, 1.0)
        if np.isfinite(paged.pyramid.flat_error).all():
            PagedArena(paged, profile).draw(selection, camera)
    finally:
        paged.close()


def load_heightmap(path):
    from vismobile.terrain.sources import load_file

    load_file(path)


ENTRY = {"glb": (load_textured, ".glb"), "objmtl": (load_textured_obj, ".obj"),
         "ply": (load_mesh, ".ply"), "stl": (load_mesh, ".stl"), "off": (load_mesh, ".off"),
         "gz": (load_mesh, ".ply.gz"), "vmt": (load_vmt, ".vmt"),
         "vmtplay": (load_vmt_play, ".vmt"), "npy": (load_heightmap, ".npy"),
         "tif": (load_heightmap, ".tif"), "vmtiles": (load_vmtiles, ".vmtiles")}
