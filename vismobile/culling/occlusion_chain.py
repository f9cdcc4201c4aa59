"""The rest of a `vfc,occlusion,tbfc` frame in one compiled call, after occlusion's compiled
frame (hiz.frame.occlusion_frame): the distinct gather of the draw nodes, tbfc's back-face test,
occlusion's triangle test and the ranking of the sent triangles as next frame's candidates
(occlusion.observe). The same kernels in the same order as CullState.finish with tbfc's and
occlusion's filters and Culler.cull's observe, so it sends exactly the same triangles; it only
saves the Python between them (issue 32: about a quarter of a W2 frame was that Python).

The Culler chains them (Culler._chain) only when vfc, occlusion and tbfc (and bfc, a render
flag) are its only stages on a static partition: any other filter would have to run between.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .facing import not_backfacing
from .gather import count_marked, extract_marked, mark_nodes
from .hiz.buffer import hidden_triangles
from .hiz.candidates import score_candidates
from .hiz.frame import top_scored
from .kernels import run_count

# Slots of chain_finish's counts.
GATHERED, FRONT, SUBPIXEL, HIDDEN, RUNS, CHAIN_SLOTS = range(6)


@njit(cache=True, nogil=True)
def chain_finish(nodes, words, masks, span, bits, summary, tops, ranges, vertices, triangles,
                 eye, tbfc_delta, gamma8, rot, near, tx, ty, width, height, move, shift, margin,
                 recede, depth, tile_max, tile_shift, tw, th, sw, sh, sample_move, normals, v0,
                 centroids, radius, areas, planes, grazing, occluders, counts):
    """(sent ids (S,) int64 sorted, next frame's history (<= occluders,) int64) for the draw
    nodes (D,) int64: their distinct triangle ids (gather: mark_nodes, count_marked,
    extract_marked, bitmap left cleared), those tbfc keeps (facing.not_backfacing with
    tbfc_delta), those occlusion's buffer test keeps (hiz.hidden_triangles with the buffer;
    neither hidden nor, with a screen, covering no pixel centre), and the best `occluders` of
    them by estimated solid angle (occlusion.observe). counts (CHAIN_SLOTS,) int64 gets the
    gathered, front-facing, sub-pixel, hidden counts and the draw batches.
    Contract: the kernels' (each errs toward keeping), as CullState.finish calls them."""
    ntops = mark_nodes(words, masks, span, nodes, bits, summary, tops, ranges)
    size = count_marked(bits, summary, tops, ntops)
    ids = np.empty(size, dtype=np.int64)
    extract_marked(bits, summary, tops, ntops, ids)
    # tbfc in place: the k-th id is read before any write at an index <= k.
    front = not_backfacing(ids, vertices, triangles, eye, tbfc_delta, gamma8, ids)
    hidden = np.empty(front, dtype=np.bool_)
    subpixel = np.empty(front, dtype=np.bool_)
    zmin = np.empty(front)
    hidden_triangles(ids[:front], vertices, triangles, eye, rot, near, tx, ty, width, height,
                     move, shift, margin, recede, depth, tile_max, tile_shift, tw, th, True, sw,
                     sh, sample_move, hidden, subpixel, zmin)
    sent = 0
    for k in range(front):
        counts[SUBPIXEL] += subpixel[k]
        counts[HIDDEN] += hidden[k]
        if not (hidden[k] or subpixel[k]):
            ids[sent] = ids[k]
            sent += 1
    out = ids[:sent]
    counts[GATHERED] += size
    counts[FRONT] += front
    counts[RUNS] += run_count(out)
    if sent == 0:
        return out, np.zeros(0, dtype=np.int64)
    score = score_candidates(out, normals, v0, centroids, radius, areas, planes, eye, grazing)
    return out, top_scored(out, score, occluders)
