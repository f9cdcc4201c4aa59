"""The page table of a paged quadtree (terrain/paged_roettger.py), read by quadtree.py's kernels.

Nodes at levels <= the page level are stored flat (quadtree's offsets[l] + bi * 2^l + bj); a
node below it lives in the slot of its page (the page level's node above it) when that page is
resident, else it has no storage (node_index -1). A page level node whose page is not resident
is never subdivided: the kernels add the page to the table's wanted list instead, and the
caller reads those pages and runs the frame again. Per-level lists of subdivided nodes start at
list_offsets (room for the held pages only).
"""
from __future__ import annotations

from numba import njit

# page_table layout: [page level, nodes per page, first slot node, wanted count, slot of each
# page (4^page level, -1 when not resident), wanted pages (as many)]
PAGE_LEVEL, PER_PAGE, BASE, WANTED, SLOTS = 0, 1, 2, 3, 4


@njit(cache=True, inline="always")
def node_index(offsets, pg, slots, l, bi, bj):
    """Storage index of node (l, bi, bj), or -1 when its page is not resident. pg: the table's
    (page level, nodes per page, first slot node) and slots its slot per page, read once per
    kernel into locals (read through the table at every node, which the kernels also write,
    refine ran 3x slower than quadtree's)."""
    lg, per_page, base = pg
    if l <= lg:
        return offsets[l] + bi * (1 << l) + bj
    k = l - lg
    slot = slots[(bi >> k) * (1 << lg) + (bj >> k)]
    if slot < 0:
        return -1
    mk = 1 << k
    local = ((1 << (2 * k)) - 4) // 3 + (bi & (mk - 1)) * mk + (bj & (mk - 1))
    return base + slot * per_page + local


@njit(cache=True, inline="always")
def table_locals(table):
    """(page level, nodes per page, first slot node) and the slot of each page."""
    return (table[PAGE_LEVEL], table[PER_PAGE], table[BASE]), table[SLOTS:]


@njit(cache=True, inline="always")
def want(table, lg, page):
    """Add page (of the 4^lg at page level lg) to the table's wanted list while it has room."""
    pages = 1 << (2 * lg)
    n = table[WANTED]
    if n < pages:
        table[SLOTS + pages + n] = page
        table[WANTED] = n + 1


@njit(cache=True, inline="always")
def may_split(pg, slots, table, l, bi, bj):
    """False (and the page wanted) for a page level node of a paged tree whose page is not
    resident: its children have no storage."""
    if pg[1] == 0 or l != pg[0]:
        return True
    page = bi * (1 << l) + bj
    if slots[page] >= 0:
        return True
    want(table, l, page)
    return False
