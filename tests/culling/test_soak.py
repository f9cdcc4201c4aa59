"""A Culler dropped is freed by reference counting alone (issue 28): no reference cycle keeps
its tree, scratch and buffers alive until the cyclic collector happens to run. Making and
dropping cullers (the viewer makes one on every Tab or stage toggle) keeps RSS flat."""
import gc
import weakref

from vismobile.culling import STAGES, Culler
from vismobile.culling.adaptive import AdaptiveCuller
from vismobile.partition import partition


def _rss_mb() -> float:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * 4096 / 1e6


def _kept_alive(make, cameras) -> list:
    """Names of what survives dropping the culler make() returns, after it culled every camera,
    with the cyclic collector off."""
    culler = make()
    for camera in cameras:
        culler.cull(camera)
    inner = getattr(culler, "_cullers", None)
    parts = {"culler": culler}
    for c in ([culler] if inner is None else list(inner.values())):
        parts.update({f"tree {id(c)}": c.tree}, **{f"{s.name} {id(c)}": s for s in c.stages})
    refs = {name: weakref.ref(obj) for name, obj in parts.items()}
    del culler, parts, c, inner
    return sorted(name for name, ref in refs.items() if ref() is not None)


def test_a_dropped_culler_is_freed_by_refcount_alone(kit):
    part = partition(kit.world("w1"), "portal", depth=1)  # every stage can run on it
    cameras = kit.random_cameras(part, 3, seed=5)
    every = "portals,vfc,cone,occlusion,cbfc,tbfc,bfc"
    makers = {name: (lambda name=name: Culler(part, [name])) for name in sorted(STAGES)}
    makers[every] = lambda: Culler(part, every)
    makers["adaptive"] = lambda: AdaptiveCuller(part, ("vfc", "occlusion", "tbfc"))
    for make in makers.values():  # numba compiles first: its compiler's own cycles hold
        _kept_alive(make, cameras)  # the frames (and the culler) that called it
    gc.collect()
    gc.disable()
    try:
        kept = {name: _kept_alive(make, cameras) for name, make in makers.items()}
    finally:
        gc.enable()
    assert kept == {name: [] for name in makers}


def test_rss_stays_flat_over_200_cullers(kit):
    # Before the fix each dropped Culler's last frame (a CullState holding closures over itself)
    # kept the whole Culler alive: 7.6 MB a Culler on W2 with the collector off.
    part = partition(kit.world("w1"), "octree", depth=4)
    cameras = kit.random_cameras(part, 2, seed=7)

    def lap():
        culler = Culler(part, "vfc,occlusion,tbfc")
        for camera in cameras:
            culler.cull(camera)

    for _ in range(20):  # warm: shared tables, numba, allocator pools
        lap()
    start = _rss_mb()
    plateau = []
    for i in range(180):
        lap()
        if i % 60 == 59:
            plateau.append(_rss_mb())
    assert max(plateau) <= start * 1.05, (start, plateau)
    assert plateau[-1] - plateau[0] <= 0.02 * start, (start, plateau)
