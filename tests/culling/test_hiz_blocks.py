"""The tile maxima's block level (culling/hiz/tiles.py: tile_max_size, build_tiles; buffer._behind):
a block holds the largest of its tiles' maxima, and a rectangle test reads blocks first yet
answers exactly as the pixel-by-pixel comparison does, with or without the blocks."""
import numpy as np

from vismobile.culling.hiz import build_tiles, tile_max_size
from vismobile.culling.hiz.buffer import _behind
from vismobile.culling.hiz.tiles import BLOCK_COLS, BLOCK_ROWS

CASES = ((120, 160, 8, 4), (24, 32, 8, 4), (20, 13, 8, 4), (9, 5, 2, 2))


def buffer(rng, width, height):
    """Depth bounds in [1, 2], a quarter of the pixels uncovered (inf), some runs of them."""
    depth = rng.uniform(1.0, 2.0, width * height)
    depth[rng.random(width * height) < 0.25] = np.inf
    depth[: width * (height // 3)] = np.minimum(depth[: width * (height // 3)], 1.2)
    return depth


def test_blocks_hold_the_largest_tile_maximum():
    rng = np.random.default_rng(3)
    for width, height, tw, th in CASES:
        rows, cols = -(-height // th), -(-width // tw)
        depth = buffer(rng, width, height)
        long_max = np.zeros(tile_max_size(rows, cols))
        build_tiles(depth, width, height, tw, th, long_max, np.zeros(rows * cols, np.bool_),
                    np.zeros(rows * cols))
        tiles = long_max[:rows * cols].reshape(rows, cols)
        blocks = long_max[rows * cols:].reshape(-(-rows // BLOCK_ROWS), -(-cols // BLOCK_COLS))
        for by in range(blocks.shape[0]):
            for bx in range(blocks.shape[1]):
                part = tiles[by * BLOCK_ROWS:(by + 1) * BLOCK_ROWS,
                             bx * BLOCK_COLS:(bx + 1) * BLOCK_COLS]
                assert blocks[by, bx] == part.max()


def test_the_rectangle_test_answers_as_the_pixels_do_with_or_without_blocks():
    rng = np.random.default_rng(4)
    margin, recede = 0.01, 1e-3
    hidden_seen = shown_seen = 0
    for width, height, tw, th in CASES:
        rows, cols = -(-height // th), -(-width // tw)
        for _ in range(5):
            depth = buffer(rng, width, height)
            short_max = np.zeros(rows * cols)
            long_max = np.zeros(tile_max_size(rows, cols))
            for tile_max in (short_max, long_max):
                build_tiles(depth, width, height, tw, th, tile_max,
                            np.zeros(rows * cols, np.bool_), np.zeros(rows * cols))
            grid = depth.reshape(height, width)
            for _ in range(300):
                x0, x1 = np.sort(rng.integers(0, width, 2))
                y0, y1 = np.sort(rng.integers(0, height, 2))
                d = grid[y0:y1 + 1, x0:x1 + 1].max()
                bound = d + margin * d * d + recede
                zmin = bound * rng.choice([0.999, 1.0, 1.001]) if np.isfinite(bound) else 3.0
                expect = bool(zmin > bound)
                for tile_max in (short_max, long_max):
                    got = _behind(x0, x1, y0, y1, zmin, depth, width, tile_max, rows, cols, tw,
                                  th, margin, recede)
                    assert got == expect, (width, height, x0, x1, y0, y1, zmin, bound)
                hidden_seen += expect
                shown_seen += not expect
    assert hidden_seen > 100 and shown_seen > 100
