"""Textured glTF scenes: base-colour textures with UVs, drawn with mipmaps (ES 1.1 profile),
power-of-two sides within the device's limit, counted against the heap; texture LOD drops
top mip levels under memory pressure. The scene is generated here, not downloaded."""
import numpy as np
import pytest
import trimesh
from PIL import Image

from vismobile.device.profile import get_profile
from vismobile.files.loader import load_world
from vismobile.render.textured import TexturedRenderer, renderer_for
from vismobile.world.camera import Camera
from vismobile.world.textures import mip_chain, pot_size

PROFILE = get_profile("ipaq-hx2490b")
RED, BLUE = (230, 30, 30), (30, 30, 230)


def checker(height=96, width=160, cell=4):
    """RGBA checkerboard of red and blue cells (sides not powers of two)."""
    rows, cols = np.indices((height, width)) // cell
    image = np.where(((rows + cols) % 2 == 0)[..., None], RED, BLUE).astype(np.uint8)
    return np.concatenate([image, np.full((height, width, 1), 255, np.uint8)], axis=2)


def textured_scene(path):
    """A 4 x 4 quad facing +z with the checker repeated 8 times, and an untextured box."""
    quad = trimesh.Trimesh([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    uv = np.array([[0, 0], [8, 0], [8, 8], [0, 8]], float)
    material = trimesh.visual.material.PBRMaterial(baseColorTexture=Image.fromarray(checker()))
    quad.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    box = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    box.apply_translation((0.0, 0.0, 1.0))
    scene = trimesh.Scene()
    scene.add_geometry(quad, node_name="a_quad", geom_name="quad")
    scene.add_geometry(box, node_name="b_box", geom_name="box")
    path.write_bytes(scene.export(file_type="glb"))
    return path


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    return load_world(textured_scene(tmp_path_factory.mktemp("tex") / "scene.glb"))


def test_gltf_textures_and_uvs_are_read(world):
    t = world.textures
    assert t is not None and len(t.images) == 1
    assert t.texture_of.tolist() == [0, -1]
    quad = world.object_ids == 0
    assert t.uv[quad].max() == pytest.approx(8.0) and t.uv[~quad].max() == 0.0
    assert t.images[0].shape == (96, 160, 4)


def test_mip_chain_is_power_of_two_down_to_one_texel():
    levels = mip_chain(checker(), 1024)
    assert levels[0].shape[:2] == (128, 128) and levels[-1].shape[:2] == (1, 1)
    assert [lv.shape[0] for lv in levels] == [128 >> k for k in range(8)]
    assert pot_size((3000, 100), 1024) == (1024, 128)  # clamped to the device's maximum
    # The 1x1 level is the checker's mean colour.
    assert np.abs(levels[-1][0, 0, :3].astype(int) - np.mean([RED, BLUE], axis=0)).max() <= 2


def test_renders_with_mipmaps_near_and_far(world):
    renderer = renderer_for(world, PROFILE)
    assert isinstance(renderer, TexturedRenderer)
    assert renderer.texture_levels == [8]
    ids = np.arange(world.triangle_count)
    near = renderer.render_rgb(ids, Camera((0.5, 0.3, 2.5), aspect=PROFILE.aspect))
    far = renderer.render_rgb(ids, Camera((0.0, 0.0, 400.0), fov=2.0, aspect=PROFILE.aspect))
    # Near: magnified cells show both texture colours (lit), as distinct pixels.
    redish = (near[..., 0] > 2 * near[..., 2]).mean()
    blueish = (near[..., 2] > 2 * near[..., 0]).mean()
    assert redish > 0.1 and blueish > 0.1
    # Far: each pixel covers many texels; trilinear mipmapping averages them to purple
    # (without mipmaps the sampled texels would alias into red and blue speckle).
    quad = (np.abs(far.astype(int) - (140, 158, 184)).sum(axis=2) > 30)  # not the clear colour
    assert quad.sum() > 50
    px = far[quad].astype(int)
    assert np.abs(px[:, 0] - px[:, 2]).mean() < 25
    # Item buffers still come from the plain path.
    renderer.draw(ids, Camera((0.5, 0.3, 2.5), aspect=PROFILE.aspect), kind="item")
    assert set(np.unique(renderer.read_ids())) - {np.uint32(0xFFFFFFFF)} <= set(ids.tolist())


def test_heap_counts_textures_and_drops_top_mips_under_pressure(world):
    memory = PROFILE.estimate_memory(world)
    expected = sum(4 * (128 >> k) ** 2 for k in range(8))
    assert memory["textures"] == expected
    small = PROFILE.with_(heap_bytes=memory["total"] - expected // 2)
    assert small.check_memory(world) <= small.heap_bytes
    assert world.textures.drop == 1  # 128x128 dropped: 64x64 .. 1x1 remain
    assert small.estimate_memory(world)["textures"] == expected - 4 * 128 * 128
    renderer = TexturedRenderer(world, small)
    assert renderer.texture_levels == [7]
    world.textures.drop = 0


def test_obj_with_mtl_textures_renders_like_the_gltf(tmp_path, world):
    Image.fromarray(checker()).save(tmp_path / "checker.png")
    (tmp_path / "quad.mtl").write_text("newmtl checker\nKd 1 1 1\nmap_Kd checker.png\n"
                                       "newmtl plain\nKd 0.5 0.5 0.5\n")
    (tmp_path / "quad.obj").write_text(
        "mtllib quad.mtl\no a_quad\nv -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\n"
        "vt 0 0\nvt 8 0\nvt 8 8\nvt 0 8\nusemtl checker\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
        "o b_plain\nv 0 0 1\nv 0.5 0 1\nv 0 0.5 1\nvt 0 0\nusemtl plain\nf 5/5 6/5 7/5\n")
    obj = load_world(tmp_path / "quad.obj")
    assert obj.textures is not None and obj.textures.texture_of.tolist() == [0, -1]
    assert obj.textures.uv[:2].max() == pytest.approx(8.0)
    camera = Camera((0.5, 0.3, 2.5), aspect=PROFILE.aspect)
    image = renderer_for(obj, PROFILE).render_rgb(np.arange(obj.triangle_count), camera)
    assert (image[..., 0] > 2 * image[..., 2]).mean() > 0.1
    assert (image[..., 2] > 2 * image[..., 0]).mean() > 0.1
    # Without the mtllib the OBJ loads untextured, as before.
    (tmp_path / "plain.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert load_world(tmp_path / "plain.obj").textures is None
