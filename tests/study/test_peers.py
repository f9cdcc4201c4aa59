"""pymartini and pydelatin against the engine's methods (both are in the test extra)."""
import numpy as np
import pytest

from vismobile.device.profile import get_profile
from vismobile.study.peers import PEERS, PeerMethod, compare, missing, peer_mesh
from vismobile.study.terrain import RoamMethod, vertex_errors
from vismobile.terrain import sources
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.raster import triangle_heights
from vismobile.terrain.roam import Roam


@pytest.fixture(scope="module")
def terrain():
    return sources.diamond_square(129, seed=3, roughness=0.5, relief=0.1)


@pytest.mark.parametrize("name", PEERS)
def test_peer_mesh_covers_the_map_within_its_error(terrain, name):
    """A closed CCW cover of the square; Delatin keeps every sample within E, Martini's E is
    checked at its split midpoints only (measured here: up to 1.3 E at the other samples)."""
    assert missing(name) is None, missing(name)
    for e in (0.05, 0.5):
        t = peer_mesh(terrain, name, e)
        n = terrain.size
        r, c = np.divmod(t, n)
        cross = ((r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0])
                 - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0]))
        assert (cross > 0).all() and cross.sum() == 2 * (n - 1) ** 2
        drawn = triangle_heights(terrain.heights.astype(float), t)
        slack = 1.0 if name == "delatin" else 2.0
        assert np.abs(drawn - terrain.heights).max() <= slack * e * 1.001 + 1e-6
    assert len(peer_mesh(terrain, name, 0.05)) > len(peer_mesh(terrain, name, 0.5))


def test_compare_matches_triangles_and_errors(terrain):
    assert all(missing(n) is None for n in PEERS), [missing(n) for n in PEERS]
    names = list(PEERS)
    profile = get_profile("ipaq-hx2490b")
    cameras = path_cameras(terrain, "lemniscate", "fast", frames=2, every=300)
    rows = compare([RoamMethod(Roam(terrain))], terrain, cameras, [1.0], profile, peers=names)
    own = rows[0]
    assert own["method"] == "roam" and own["sample_error_px"] <= 1.0
    for name in names:
        by_triangles = next(r for r in rows if r["method"] == f"{name} vs roam"
                            and r["match"] == "triangles")
        by_error = next(r for r in rows if r["method"] == f"{name} vs roam"
                        and r["match"] == "error")
        assert abs(by_triangles["triangles"] - own["triangles"]) <= 0.25 * own["triangles"]
        assert by_error["max_error"] == own["max_error"]
        # A view-independent mesh with the method's largest world error everywhere.
        peer = PeerMethod(terrain, name, own["max_error"])
        drawn = peer.heights(peer.mesh())
        assert vertex_errors(terrain, drawn, cameras[0], profile.resolution).size > 0
