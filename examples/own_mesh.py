"""Your own mesh through the pipeline: load -> partition -> cull -> render a PNG.

    python examples/own_mesh.py [MESH] [--out own_mesh.png]

MESH is any file vismobile.load_world reads (.obj .ply .stl .off .glb .gltf, optionally .gz); the
camera then looks at it from outside. Without MESH a small room is built with trimesh, its
walls turned to face inward (trimesh makes boxes face outward, which back-face culling would
remove when seen from inside), and the camera stands in it.
"""
import argparse

import numpy as np
import trimesh
from PIL import Image

from vismobile import Camera, Culler, World, get_profile, load_world, partition, render_rgb


def demo_room() -> World:
    """A 10 x 3 x 8 m room facing inward, with a ball and a crate on its floor."""
    room = trimesh.creation.box(extents=(10, 3, 8))
    room.apply_translation((0, 1.5, 0))
    room.invert()  # faces toward the interior: the viewer is inside
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.6)
    ball.apply_translation((1.5, 0.6, -2))
    crate = trimesh.creation.box(extents=(1, 1, 1))
    crate.apply_translation((-2, 0.5, -1))
    scene = trimesh.Scene()
    for name, mesh in (("room", room), ("ball", ball), ("crate", crate)):
        scene.add_geometry(mesh, node_name=name, geom_name=name)
    return World.from_trimesh(scene, name="room")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mesh", nargs="?", help="mesh file (default: a room built here)")
    parser.add_argument("--out", default="own_mesh.png", help="PNG to write")
    parser.add_argument("--structure", default="octree:3", help="e.g. octree:3, grid:4, portal:1, bsp, "
                                                              "bsp:min_leaf=8")
    parser.add_argument("--cull", default="vfc+bfc", help="culling stages joined by +")
    args = parser.parse_args(argv)

    world = load_world(args.mesh) if args.mesh else demo_room()
    print(world)
    tree = partition(world, args.structure)  # the CLI's grammar: octree:3, grid:4, bsp, ...
    print(tree)

    low, high = world.extent
    centre, size = (low + high) / 2, float(np.max(high - low))
    # Inside the room, 1.6 m up near its +z wall; outside a mesh, back along +z.
    eye = (centre[0], 1.6, high[2] - 0.5) if not args.mesh else centre + (0, 0, 1.5 * size)
    profile = get_profile("desktop")
    camera = Camera(tuple(eye), yaw=0.0, pitch=-5.0, aspect=profile.aspect)
    result = Culler(tree, args.cull).cull(camera)
    print(f"{len(result.triangles)} of {world.triangle_count} triangles sent "
          f"({args.structure}, {args.cull})")
    image = render_rgb(world, result.triangles, camera, profile, cull_back=result.cull_back)
    Image.fromarray(image).save(args.out)
    print(f"wrote {args.out} ({image.shape[1]}x{image.shape[0]})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
