"""CLI commands, one module each: add_parser(subparsers) -> parser, run(args) -> exit code."""

# Help text of every command's WORLD argument.
WORLD_HELP = ("thesis world w1..w6 (built on first use) or a mesh file: .obj .ply .stl .off "
              ".glb .gltf, optionally .gz")
