"""The buffer's triangle test at the screen's pixel centres (culling/hiz/buffer.py,
_pixel_centres_behind): with the device's screen a triangle is tested only where its fragments
can be, the pixel centres, against the buffer pixels within the occluders' shift of each."""
import numpy as np
import pytest

from .test_hiz import TX, TY, H, W, camera_triangle, shape_test


def screen_test(tris, depth, move=0.0, shift=0.0, screen=(2 * W, 2 * H)):
    """test_hiz.shape_test with the centre test of a 2x screen by default."""
    return shape_test(tris, depth, move, shift, screen)


def centre_fragments_in_front(tri, depth, move, shift_px, rng, screen=(2 * W, 2 * H)):
    """How many fragments of 100 moved copies of the camera-space triangle tri (3, 3) (corners
    moved by up to move per coordinate), drawn at the sw x sh screen's pixel centres only, are
    not behind every buffer pixel within shift_px (buffer pixels) of their centre."""
    sw, sh = screen
    i, j = np.meshgrid(np.arange(sw), np.arange(sh))
    u, v = (2 * (i.ravel() + 0.5) / sw - 1) * TX, (2 * (j.ravel() + 0.5) / sh - 1) * TY
    bx, by = (i.ravel() + 0.5) * W / sw, (j.ravel() + 0.5) * H / sh
    # The largest depth bound over the pixels within shift_px of each centre.
    x0 = np.clip(np.floor(bx - shift_px), 0, W - 1).astype(int)
    x1 = np.clip(np.floor(bx + shift_px), 0, W - 1).astype(int)
    y0 = np.clip(np.floor(by - shift_px), 0, H - 1).astype(int)
    y1 = np.clip(np.floor(by + shift_px), 0, H - 1).astype(int)
    bound = np.array([depth[a:b + 1, c:d + 1].max() for a, b, c, d in zip(y0, y1, x0, x1)])
    front = 0
    for moved in tri + rng.uniform(-move, move, size=(100, 3, 3)):
        p = moved[:, :2] / moved[:, 2:] / [TX, TY]  # corners in tangent-normalised x, y
        q = np.stack([u / TX, v / TY], 1)
        e = [(p[(k + 1) % 3, 0] - p[k, 0]) * (q[:, 1] - p[k, 1])
             - (p[(k + 1) % 3, 1] - p[k, 1]) * (q[:, 0] - p[k, 0]) for k in range(3)]
        inside = ((e[0] >= 0) & (e[1] >= 0) & (e[2] >= 0)) | ((e[0] <= 0) & (e[1] <= 0)
                                                              & (e[2] <= 0))
        normal = np.cross(moved[1] - moved[0], moved[2] - moved[0])
        rays = np.stack([u, v, np.ones_like(u)], 1)[inside]
        z = (normal @ moved[0]) / (rays @ normal)  # the moved plane's depth on each ray
        front += int((z <= bound[inside]).sum())
    return front


@pytest.mark.parametrize("move, shift_px", [(0.0, 0.0), (0.02, 0.0), (0.0, 0.3), (0.01, 0.6)])
def test_the_centre_test_keeps_every_fragment_at_the_screens_centres(move, shift_px):
    # The contract of the per-centre plane bound (hiz.buffer._pixel_centres_behind): a triangle
    # called hidden with a 2x screen has every fragment a moved copy draws at a screen centre
    # behind every buffer pixel within the occluders' shift of that centre; and the centres
    # hide some triangles the whole pixel squares keep (contact with uneven buffers).
    rng = np.random.default_rng(34)
    checked, by_centres = 0, 0
    shift = shift_px * TX / (0.5 * W)
    for _ in range(40):
        depth = np.repeat(np.repeat(rng.uniform(4.0, 8.0, size=(H // 2, W // 2)), 2, 0), 2, 1)
        depth[rng.random((H, W)) < 0.02] = np.inf
        px = rng.uniform(-2.0, [W + 2.0, H + 2.0], size=(40, 3, 2))
        tris = np.array([camera_triangle(p, 1.0, W, H) for p in px])
        tris *= rng.uniform(5.0, 10.0, size=(40, 3, 1))
        hidden = screen_test(tris, depth, move=move, shift=shift)
        square = screen_test(tris, depth, move=move, shift=shift, screen=(0, 0))
        assert not (square & ~hidden).any()  # the centres never keep what the squares hide
        for t in tris[hidden]:
            assert centre_fragments_in_front(t, depth, move, shift_px, rng) == 0
            checked += 1
        by_centres += int((hidden & ~square).sum())
    assert checked > 15 and by_centres > 3
