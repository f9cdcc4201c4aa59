"""GeoTIFF DEMs written by Pillow's libtiff, read by terrain/geotiff (tifffile): the GDAL_NODATA
tag becomes holes, the pixel scale the spacing, float predictor 3 and deflate decode; a
malformed file is one line, exit 2."""
import numpy as np
import pytest
from PIL import Image, TiffImagePlugin

from vismobile.errors import WorldError
from vismobile.terrain import geotiff, sources


def write_geotiff(path, heights, nodata="-9999", scale=(30.0, 30.0, 0.0), predictor=3):
    info = TiffImagePlugin.ImageFileDirectory_v2()
    if nodata is not None:
        info[geotiff.GDAL_NODATA] = nodata
        info.tagtype[geotiff.GDAL_NODATA] = 2  # ASCII
    if scale is not None:
        info[geotiff.MODEL_PIXEL_SCALE] = scale
        info.tagtype[geotiff.MODEL_PIXEL_SCALE] = 12  # DOUBLE
    info[317] = predictor
    Image.fromarray(heights).save(path, compression="tiff_adobe_deflate", tiffinfo=info)


@pytest.fixture
def dem():
    h = np.add.outer(np.arange(40.0), 2 * np.arange(70.0)).astype(np.float32)
    h[10:14, 20:30] = -9999.0
    return h


def test_nodata_and_pixel_scale_come_from_the_tags(dem, tmp_path):
    write_geotiff(tmp_path / "d.tif", dem)
    hm = sources.load_file(tmp_path / "d.tif", spacing=None)
    assert hm.size == 129 and hm.spacing == 30.0  # padded: 70 columns -> 2^7 + 1
    assert (~hm.valid[:40, :70]).sum() == 40 and hm.valid[:40, :70].sum() == 40 * 70 - 40
    kept = hm.valid[:40, :70]
    assert np.allclose(hm.heights[:40, :70][kept], dem[dem > -9999], atol=1e-2)
    given = sources.load_file(tmp_path / "d.tif", spacing=2.0, nodata=0.0)
    assert given.spacing == 2.0 and (~given.valid[:40, :70]).sum() == 1  # the value 0 only


def test_malformed_geotiffs_name_the_file(dem, tmp_path, capsys):
    from vismobile.app.cli import main

    write_geotiff(tmp_path / "text.tif", dem, nodata="none at all")
    with pytest.raises(WorldError, match="text.tif.*GDAL_NODATA"):
        sources.load_file(tmp_path / "text.tif")
    write_geotiff(tmp_path / "oblong.tif", dem, scale=(30.0, 10.0, 0.0))
    with pytest.raises(WorldError, match="oblong.tif.*square"):
        sources.load_file(tmp_path / "oblong.tif", spacing=None)
    write_geotiff(tmp_path / "cut.tif", dem)
    data = (tmp_path / "cut.tif").read_bytes()
    (tmp_path / "cut.tif").write_bytes(data[:len(data) // 2])
    assert main(["terrain", "build", str(tmp_path / "cut.tif"), "-o",
                 str(tmp_path / "cut.vmt")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cut.tif" in err[0] and not (tmp_path / "cut.vmt").exists()


def test_decoder_messages_stay_off_the_terminal(tmp_path):
    """A corrupt strip (tifffile and its codecs log what they skip): the CLI says one line."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
    import hostile

    argv, named = hostile.CASES["tif_corrupt_strip"](tmp_path)
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=str(root), VISMOBILE_STATUS="off")
    result = subprocess.run([sys.executable, "-m", "vismobile", *map(str, argv)], env=env,
                            capture_output=True, text=True, timeout=300)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and str(named) in lines[0], result.stderr
