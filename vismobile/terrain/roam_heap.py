"""Binary min-heaps on parallel flat arrays (keys float64, values int64; ties broken by the
smaller value, so runs are deterministic) for ROAM's split, merge and wake-up queues
(roam_frame.py), and the count of due wake-ups that decides a walking frame (roam.py)."""
from __future__ import annotations

import numpy as np
from numba import njit


# _reserve grows a heap's arrays.
@njit(cache=True)
def _reserve(keys, vals, size, extra):
    if size + extra <= keys.shape[0]:
        return keys, vals
    nk = np.empty(2 * (size + extra), np.float64)
    nv = np.empty(2 * (size + extra), np.int64)
    nk[:size] = keys[:size]
    nv[:size] = vals[:size]
    return nk, nv


@njit(cache=True, inline="always")
def _push(keys, vals, size, key, val):
    i = size
    keys[i], vals[i] = key, val
    while i > 0:
        p = (i - 1) >> 1
        if keys[p] < keys[i] or (keys[p] == keys[i] and vals[p] <= vals[i]):
            break
        keys[p], keys[i] = keys[i], keys[p]
        vals[p], vals[i] = vals[i], vals[p]
        i = p
    return size + 1


@njit(cache=True)
def _pop(keys, vals, size):
    size -= 1
    keys[0], vals[0] = keys[size], vals[size]
    i = 0
    while True:
        lft = 2 * i + 1
        if lft >= size:
            break
        m = lft
        rgt = lft + 1
        if rgt < size and (keys[rgt] < keys[lft]
                           or (keys[rgt] == keys[lft] and vals[rgt] < vals[lft])):
            m = rgt
        if keys[i] < keys[m] or (keys[i] == keys[m] and vals[i] <= vals[m]):
            break
        keys[m], keys[i] = keys[i], keys[m]
        vals[m], vals[i] = vals[i], vals[m]
        i = m
    return size


@njit(cache=True)
def _due(keys, size, travel, cap):
    """How many entries of the min-heap keys[:size] are <= travel, counted up to cap (a
    walk over the heap's nodes that are due: O(min(due, cap)))."""
    if size == 0 or keys[0] > travel:
        return 0
    stack = np.empty(2 * cap + 4, np.int64)
    stack[0] = 0
    top = 1
    count = 0
    while top > 0 and count < cap:
        top -= 1
        i = stack[top]
        count += 1
        for j in (2 * i + 1, 2 * i + 2):
            if j < size and keys[j] <= travel:
                stack[top] = j
                top += 1
    return count
