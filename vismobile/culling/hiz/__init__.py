"""Compiled kernels of the `occlusion` stage: a conservative hierarchical (tiled) depth buffer in
the style of Masked Occlusion Culling (Hasselgren, Andersson, Akenine-Moller 2016) and the
hierarchical Z-buffer (Greene 1993), numba, cached on disk.

Screen. Camera space: x right, y up, z depth along the view direction (positive in front);
pixel coordinates px = (x / (z tx) + 1) W / 2, py = (y / (z ty) + 1) H / 2, pixel (i, j) is
[i, i+1] x [j, j+1]. The buffer holds per pixel a depth bound D: every point of the pixel is
covered by an occluder whose depth there is <= D (inf: no such bound). Tiles of tw x th pixels
hold the maximum (farthest) D of their pixels and whether any pixel is covered; a tested
rectangle is first compared with its blocks' maxima (2 x 4 tiles), then with the tiles of a
block whose maximum fails, and only partly covered tiles, whose maximum fails, are read pixel
by pixel (the exact maximum over the rectangle).

Modules: raster.py (occluders into the buffer: rasterise, stamp_near), tiles.py (the tiles'
maxima and their blocks, the occluders' shift per tile), buffer.py (tested rectangles,
hidden_triangles), walks.py (node boxes from the root: cull_nodes, frustum_cull_nodes),
candidates.py (which occluders: gather, score, facing), frame.py (the stage's usual frame
calling them in one compiled call: occlusion_frame).
"""
from .buffer import SAMPLE_SLACK_PX, covers_no_sample, hidden_triangles, screen_rect
from .candidates import (facing_occluders, gather_candidates, gather_shell_candidates,
                         lod_ancestors, score_candidates)
from .raster import DEPTH_SLACK, GUARD_PX, SAMPLE_HALF, SLACK_PX, rasterise, stamp_near
from .tiles import build_tiles, shift_table_size, tile_max_size, tile_shift_bound, tile_shifts
from .walks import CENTRE_SPAN, cull_nodes, frustum_cull_nodes

__all__ = ["CENTRE_SPAN", "DEPTH_SLACK", "GUARD_PX", "SAMPLE_HALF", "SAMPLE_SLACK_PX", "SLACK_PX",
           "build_tiles", "covers_no_sample", "cull_nodes", "facing_occluders",
           "frustum_cull_nodes", "gather_candidates", "gather_shell_candidates",
           "hidden_triangles", "lod_ancestors", "rasterise", "score_candidates", "screen_rect",
           "shift_table_size", "stamp_near", "tile_max_size", "tile_shift_bound",
           "tile_shifts"]
