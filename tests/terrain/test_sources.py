import numpy as np
import pytest
from PIL import Image

from vismobile.errors import WorldError
from vismobile.terrain import sources


def test_diamond_square_is_deterministic_and_seeded():
    a = sources.diamond_square(65, seed=3)
    b = sources.diamond_square(65, seed=3)
    c = sources.diamond_square(65, seed=4)
    assert np.array_equal(a.samples, b.samples) and a.digest() == b.digest()
    assert not np.array_equal(a.samples, c.samples)
    assert a.size == 65 and np.isclose(np.ptp(a.heights), 0.25 * 64, rtol=1e-4)


def test_diamond_square_roughness_shapes_the_spectrum():
    """Lower roughness makes a smoother surface: smaller mean neighbour difference."""
    smooth = sources.diamond_square(129, seed=0, roughness=0.35).heights
    rough = sources.diamond_square(129, seed=0, roughness=0.75).heights
    assert np.abs(np.diff(smooth, axis=1)).mean() < np.abs(np.diff(rough, axis=1)).mean()


@pytest.mark.parametrize("name", sorted(sources.DEMS))
def test_matplotlib_dems_resample_to_grid(name):
    hm = sources.dem(name, 129)
    assert hm.size == 129 and np.ptp(hm.heights) > 100  # real relief in metres
    assert hm.spacing > 0


def test_resample_keeps_grid_inputs_and_corners():
    h = np.arange(25.0).reshape(5, 5)
    assert np.array_equal(sources.resample(h, 5), h)
    r = np.arange(12.0).reshape(3, 4)
    out = sources.resample(r, 9)
    assert out[0, 0] == r[0, 0] and out[-1, -1] == r[-1, -1] and out[0, -1] == r[0, -1]


def test_load_files(tmp_path):
    h = (np.add.outer(np.arange(20), np.arange(30)) * 1000).astype(np.uint16)
    Image.fromarray(h).save(tmp_path / "h.png")  # 16-bit greyscale
    np.save(tmp_path / "h.npy", h.astype(np.float32))
    Image.fromarray(h.astype(np.float32)).save(tmp_path / "h.tif")
    maps = [sources.load_file(tmp_path / f"h.{ext}", vertical=0.01, fit="resample")
            for ext in ("png", "npy", "tif")]
    for hm in maps:
        assert hm.size == 33  # next 2^n+1 above 30
        assert np.isclose(hm.heights.max(), 0.01 * h.max(), rtol=1e-3)
        assert np.isclose(hm.spacing, 29 / 32)
        assert not hm.holes
    assert np.allclose(maps[0].heights, maps[1].heights, atol=1e-2)
    # The default pads: every sample kept at its spacing, the padding no data.
    for ext in ("png", "npy", "tif"):
        hm = sources.load_file(tmp_path / f"h.{ext}", vertical=0.01)
        assert hm.size == 33 and hm.spacing == 1.0 and hm.holes
        assert hm.valid[:20, :30].all() and not hm.valid[20:].any() and not hm.valid[:, 30:].any()
        assert np.allclose(hm.heights[:20, :30], 0.01 * h, atol=0.01 * h.max() / 65535 + 1e-9)


def test_bad_files_name_the_file(tmp_path):
    with pytest.raises(WorldError, match="missing.png"):
        sources.load_file(tmp_path / "missing.png")
    (tmp_path / "junk.png").write_bytes(b"not a png")
    with pytest.raises(WorldError, match="junk.png"):
        sources.load_file(tmp_path / "junk.png")
    np.save(tmp_path / "hole.npy", np.array([[1.0, np.inf], [2.0, 3.0]]))
    with pytest.raises(WorldError, match="hole.npy.*infinite"):
        sources.load_file(tmp_path / "hole.npy")
    np.save(tmp_path / "none.npy", np.full((3, 3), -9999.0))
    with pytest.raises(WorldError, match="none.npy.*no valid sample"):
        sources.load_file(tmp_path / "none.npy", nodata=-9999)
    np.save(tmp_path / "flat.npy", np.arange(5.0))
    with pytest.raises(WorldError, match="2-D"):
        sources.load_file(tmp_path / "flat.npy")
