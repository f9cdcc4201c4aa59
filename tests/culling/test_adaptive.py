"""Adaptive culling: stages are switched off when they cost more than they save, and back on."""
from dataclasses import dataclass, field

import numpy as np

from vismobile.culling.adaptive import AdaptiveCuller


@dataclass
class _Result:
    triangles: np.ndarray
    stats: dict = field(default_factory=dict)


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def _factory(clock, cost_ms, removes):
    """Fake Culler: each stage costs cost_ms[stage] and removes removes[stage](frame) ids."""
    frame = {"n": 0}

    def make(partition, stages):
        class Fake:
            def cull(self, camera):
                clock.now += sum(cost_ms[s] for s in stages) / 1e3
                kept = 1000 - sum(removes[s](camera) for s in stages)
                return _Result(np.arange(kept), {"triangles_sent": kept, "draw_batches": 1})
        return Fake()
    return make, frame


def test_a_stage_that_does_not_pay_is_switched_off_and_recorded():
    clock = _Clock()
    make, _ = _factory(clock, {"vfc": 0.1, "cone": 2.0, "bfc": 0.0},
                       {"vfc": lambda f: 500, "cone": lambda f: 10, "bfc": lambda f: 0})
    culler = AdaptiveCuller(None, ["vfc", "bfc", "cone"], window=3, probe_every=2,
                            ms_per_triangle=0.01, culler_factory=make, clock=clock)
    for frame in range(20):
        result = culler.cull(frame)
    assert culler.stages == ("vfc", "bfc")
    assert [e["stage"] for e in culler.events] == ["cone"]
    assert culler.events[0]["action"] == "off" and culler.events[0]["cost_ms"] > 1.9
    assert result.stats["active_stages"] == "vfc+bfc"
    assert culler.cull_back


def test_a_stage_is_switched_back_on_when_it_pays_again():
    clock = _Clock()
    make, _ = _factory(clock, {"cone": 1.0}, {"cone": lambda f: 10 if f < 20 else 900})
    culler = AdaptiveCuller(None, ["cone"], window=2, probe_every=2, ms_per_triangle=0.01,
                            culler_factory=make, clock=clock)
    for frame in range(40):
        culler.cull(frame)
    assert [(e["stage"], e["action"]) for e in culler.events] == [("cone", "off"),
                                                                  ("cone", "on")]
    assert culler.stages == ("cone",)


def test_without_a_render_cost_nothing_is_switched():
    clock = _Clock()
    make, _ = _factory(clock, {"cone": 5.0}, {"cone": lambda f: 0})
    culler = AdaptiveCuller(None, ["cone"], window=1, probe_every=1, culler_factory=make,
                            clock=clock)
    for frame in range(10):
        culler.cull(frame)
    assert culler.events == [] and culler.stages == ("cone",)


def test_render_cost_is_learnt_from_observed_frames():
    culler = AdaptiveCuller(None, [], culler_factory=lambda p, s: None)
    for n in range(0, 10000, 1000):
        culler.observe_render(1.0 + 2e-4 * n, {"triangles_sent": n, "draw_batches": 1 + n // 5000})
    assert np.isclose(culler.ms_per_triangle, 2e-4, rtol=1e-6)


def test_wraps_the_real_culler():
    import trimesh

    from vismobile.world.camera import Camera
    from vismobile.culling import Culler
    from vismobile.partition import partition
    from vismobile.world.world import World

    mesh = trimesh.creation.icosphere(subdivisions=2)
    world = World(mesh.vertices, mesh.faces)
    tree = partition(world, "octree", depth=2)
    adaptive = AdaptiveCuller(tree, ["vfc", "bfc", "cbfc"], window=1, probe_every=1,
                              ms_per_triangle=0.0)
    camera = Camera((0, 0, 5))
    result = adaptive.cull(camera)
    plain = Culler(tree, ["vfc", "bfc", "cbfc"]).cull(camera)
    assert np.array_equal(result.triangles, plain.triangles)
    for _ in range(3):
        adaptive.cull(camera)
    # Whatever was switched (timing-dependent), the driver flag stays and nothing is lost.
    assert "bfc" in adaptive.stages and adaptive.cull_back
    assert set(adaptive.cull(camera).triangles) >= set(plain.triangles)
