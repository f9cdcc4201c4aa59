"""CLI commands, one module each: add_parser(subparsers) -> parser, run(args) -> exit code."""

# Help text of every command's WORLD argument.
WORLD_HELP = ("thesis world w1..w7 (built on first use; w7 moves) or a mesh file: .obj .ply "
              ".stl .off .glb .gltf (a .glb/.gltf animation moves its objects), optionally .gz")
MOTION_HELP = ("JSON motion file moving the world's objects by name (docs/dynamic.md); w7 "
               "brings its own, a .glb/.gltf its animation")
FPS_HELP = "an animated scene's frames per second: frame f shows t = f / FPS s (default 30)"
# Valid values, spelled out here so `--help` needs no heavy import (tests/test_cli.py checks
# them against culling.STAGES, profile.PROFILES and partition.KINDS).
STAGE_NAMES = ("vfc", "vfc_thesis", "bfc", "cbfc", "cbfc_thesis", "cone", "tbfc", "occlusion",
               "occlusion_thesis", "portals", "pvs", "horizon")
PROFILE_NAMES = ("ipaq-hx2490b", "nokia-n82", "desktop")
CULL_HELP = ("culling stages joined by + (a , works too), or none; stages: "
             + ", ".join(STAGE_NAMES) + " (portals needs a portal structure)")
PROFILE_HELP = "device profile: " + ", ".join(PROFILE_NAMES)
WORLDS_DIR_HELP = ("where thesis worlds are built and kept (default: $VISMOBILE_WORLDS, worlds/ "
                   "in a source checkout, else ~/.cache/vismobile/worlds)")
STRUCTURE_HELP = ("none, grid[:N], octree[:N], portal[:N], bsp, kdtree, or KIND:key=value,... "
                  "(N: octree depth 1..8, portal depth 1..3, grid slabs per axis; "
                  "kdtree:split=median,max_depth=N,min_leaf=N)")
FRAMES_HELP = ("frames to play: all, stride:N (every Nth) or sample:N (N evenly spaced plus "
               "the waypoints)")
# play and view start alike: the same structure and stages (issue 31).
DEFAULT_STRUCTURE = "octree:4"
DEFAULT_CULL = "vfc"
FIX_WINDING_HELP = ("first reverse triangles so that triangles sharing an edge agree and closed "
                    "rooms face their interior (closed solids face out); `vismobile info` "
                    "reports what it would change")

REPAIR_HELP = ("repair the world's geometry first: tjunctions splits every triangle whose edge "
               "passes another triangle's vertex, so creases are shared corner to corner and "
               "the rasteriser leaves no crack (triangle ids change; a .vmp records it)")
REPAIRS = ("none", "tjunctions")


def fix_winding(world, enabled: bool, eyes=None):
    """world with its winding fixed (winding.fixed_world_said; eyes: the trajectory's camera
    positions, if any) when enabled."""
    if not enabled:
        return world
    from ..world.winding import fixed_world_said

    return fixed_world_said(world, eyes)


# Stages that remove triangles facing away from the eye (culling.BACKFACE_STAGES; tests check).
BACKFACE_NAMES = ("bfc", "cbfc", "cbfc_thesis", "cone", "tbfc")
THESIS_WORLDS = ("w1", "w2", "w3", "w4", "w5", "w6", "w7")


def warn_winding(world, stages, source, eyes=None, fixed=False, stream=None):
    """One stderr line when a back-face stage is among stages and closed rooms of world face
    outward (winding.check_winding; trimesh's boxes do), so that back-face culling would blank
    the walls seen from inside. Returns the line, or None. Skipped for the thesis worlds (their
    winding is built right and tested) and after --fix-winding (fixed)."""
    import sys

    on = [s for s in stages if s in BACKFACE_NAMES]
    if fixed or not on or str(source).lower() in THESIS_WORLDS:
        return None
    from ..world.winding import check_winding

    report = check_winding(world, eyes)
    if not report.room_faces_outward:
        return None
    line = (f"warning: {source}: {report.room_faces_outward:,} of {report.room_faces:,} room "
            f"triangles face away from the room's interior, so back-face culling "
            f"({'+'.join(on) if len(on) < len(BACKFACE_NAMES) else 'any back-face stage'}) removes the walls seen from inside and frames may be blank; "
            "pass --fix-winding (`vismobile info` reports the winding)")
    print(line, file=sys.stderr if stream is None else stream)
    return line


def default_trajectory(world, given):
    """The trajectory a command plays: the given path, else the thesis's path for w1..w6
    (W7's own for w7);
    TrajectoryError for a mesh without one."""
    if given is not None:
        return given
    if str(world).lower() in THESIS_WORLDS:
        from ..study.thesis import trajectory_for

        return trajectory_for(str(world).lower())
    from ..errors import TrajectoryError

    raise TrajectoryError(f"{world}: not a thesis world (w1..w7), so it needs --trajectory CSV; "
                          f"`vismobile trajectory generate {world} -o walk.csv` makes one")


def default_cull(cull, structure):
    """--cull as given, else DEFAULT_CULL; "none" without a partition (nothing to cull with)."""
    if cull is not None:
        return cull
    return "none" if str(structure).strip().lower() in ("none", "") else DEFAULT_CULL
