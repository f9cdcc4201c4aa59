"""Device profiles: Table 5.1 facts, fixed16.16 quantisation and range, heap budget refusal."""
import numpy as np
import pytest

from vismobile import Profile, ProfileError
from vismobile.world.camera import Camera
from vismobile.device.profile import (FIXED_LIMIT, PROFILES, from_fixed, get_profile, partition_bytes,
                               to_fixed)
from vismobile.render import Renderer, item_buffer
from vismobile.world.world import World

MB = 1 << 20


def box_world(size=1.0, offset=(0.0, 0.0, 0.0)):
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    faces = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
             [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    return World(corners * size + np.asarray(offset), faces, name="box")


def test_the_thesis_devices():
    ipaq, n82 = get_profile("ipaq-hx2490b"), get_profile("nokia-n82")
    assert set(PROFILES) == {"ipaq-hx2490b", "nokia-n82", "desktop"}
    assert ipaq.resolution == n82.resolution == (240, 320) and ipaq.aspect == 0.75
    assert (ipaq.heap_bytes, n82.heap_bytes) == (64 * MB, 128 * MB)
    assert (ipaq.gpu, n82.gpu) == (False, True)
    assert "520 MHz" in ipaq.cpu and "332 MHz" in n82.cpu
    for profile in PROFILES.values():
        assert profile.index_type == "uint16" and profile.max_batch_vertices == 65_535
        assert profile.batch_triangles == 21_845


def test_unknown_names_and_formats_are_refused():
    with pytest.raises(ProfileError, match="unknown profile 'ipaq'"):
        get_profile("ipaq")
    with pytest.raises(ProfileError, match="vertex format"):
        get_profile("desktop", "fixed8.8")
    with pytest.raises(ProfileError, match="uint16"):
        get_profile("desktop").with_(index_type="uint32")
    with pytest.raises(ProfileError, match="max_batch_vertices"):
        get_profile("desktop").with_(max_batch_vertices=65_536)


def test_fixed_quantisation_error_is_at_most_half_a_step():
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.uniform(-FIXED_LIMIT, FIXED_LIMIT, 10_000),
                             rng.uniform(-1, 1, 10_000), [FIXED_LIMIT, -FIXED_LIMIT, 0.0]])
    raw = to_fixed(values)
    assert raw.dtype == np.int32
    assert np.max(np.abs(from_fixed(raw) - values)) <= 2.0 ** -17
    assert to_fixed([1.0, -0.5, 2.0 ** -16]).tolist() == [65536, -32768, 1]


@pytest.mark.parametrize("bad", [32767.5, -40000.0, np.inf, np.nan])
def test_fixed_refuses_coordinates_out_of_range(bad):
    with pytest.raises(ProfileError, match=r"32767.*largest \|coordinate\|"):
        to_fixed([[0.0, 1.0, bad]], "world 'x'")


def test_a_translated_world_refuses_fixed_but_renders_in_float():
    fixed = get_profile("ipaq-hx2490b", "fixed16.16")
    far_away = box_world(10.0, offset=(40_000.0, 0.0, 0.0))
    with pytest.raises(ProfileError, match=r"world 'box'.*40,010"):
        Renderer(far_away, fixed)
    camera = Camera((40_005.0, 5.0, 40.0), aspect=fixed.aspect)
    ids = item_buffer(far_away, None, camera, get_profile("ipaq-hx2490b"))
    assert len(np.unique(ids)) > 2


def test_fixed_and_float_draw_the_same_small_world():
    world = box_world(4.0, offset=(-2.0, -2.0, -12.0))
    camera = Camera((1.0, 3.0, 0.0), yaw=5.0, pitch=-10.0, aspect=0.75)
    ids_float = item_buffer(world, None, camera, get_profile("ipaq-hx2490b"), cull_back=True)
    ids_fixed = item_buffer(world, None, camera, get_profile("ipaq-hx2490b", "fixed16.16"),
                            cull_back=True)
    assert len(np.unique(ids_float)) > 3
    assert (ids_float == ids_fixed).mean() > 0.999


class _FakePartition:
    kind = "octree"
    ARRAYS = ("node_bounds", "tri_refs")

    def __init__(self, nodes, refs):
        self.node_bounds = np.zeros((nodes, 2, 3))
        self.tri_refs = np.zeros(refs, np.int32)
        self.extras = {"planes": np.zeros((4, 4))}


def test_memory_estimate_counts_buffers_geometry_and_partition():
    world = box_world()
    partition = _FakePartition(10, 100)
    parts = get_profile("nokia-n82").estimate_memory(world, partition)
    assert parts["vertex_buffers"] == 12 * 3 * 28
    assert parts["index_buffers"] == 12 * 3 * 2
    assert parts["partition"] == partition_bytes(partition) == 10 * 48 + 100 * 4 + 128
    assert parts["total"] == sum(v for k, v in parts.items() if k != "total")


def test_heap_refusal_names_both_sizes():
    world = box_world()
    tiny = get_profile("ipaq-hx2490b").with_(heap_bytes=2000)
    need = tiny.estimate_memory(world, _FakePartition(10, 100))["total"]
    with pytest.raises(ProfileError) as error:
        tiny.check_memory(world, _FakePartition(10, 100))
    message = str(error.value)
    assert f"{need:,} bytes" in message and "2,000 bytes" in message
    assert "octree" in message and "ipaq-hx2490b" in message
    assert get_profile("ipaq-hx2490b").check_memory(world) == tiny.estimate_memory(world)["total"]


def test_profile_is_exported():
    assert Profile is type(get_profile("desktop"))


@pytest.mark.parametrize("name, path", [("w1", "indoor.csv"), ("w5", "outdoor.csv")])
def test_fixed_point_draws_the_thesis_worlds_like_float(name, path):
    from pathlib import Path

    from vismobile.scenes.thesis import generate
    from vismobile.world.trajectory import Trajectory

    world = generate(name)
    trajectory = Trajectory.load(Path(__file__).resolve().parents[1] / "trajectories" / path)
    plain, fixed = get_profile("ipaq-hx2490b"), get_profile("ipaq-hx2490b", "fixed16.16")
    fixed.check_memory(world)
    for frame in sorted(trajectory.waypoints.values())[:3]:
        camera = trajectory.camera(frame, plain.aspect)
        a = item_buffer(world, None, camera, plain, cull_back=True)
        b = item_buffer(world, None, camera, fixed, cull_back=True)
        assert (a == b).mean() > 0.9999
    with pytest.raises(ProfileError, match=f"world '{name}'.*32767"):
        Renderer(world.transformed(1.0, (0.0, 0.0, -40_000.0)), fixed)


def test_device_cost_figures_belong_to_the_thesis_devices():
    ipaq, n82 = get_profile("ipaq-hx2490b").cost, get_profile("nokia-n82").cost
    assert get_profile("desktop").cost is None  # measured on this machine
    assert (ipaq.clock_mhz, n82.clock_mhz) == (520.0, 332.0)  # Table 5.1
    # No FPU on the PXA270: a float operation costs far more than on the ARM11's VFP.
    assert ipaq.float_op_cycles > 5 * n82.float_op_cycles
    # The GPU-less iPaq pays more per triangle than the N82.
    assert ipaq.render_triangle_us > n82.render_triangle_us > 0
    assert ipaq.render_base_ms > n82.render_base_ms > 0
    assert "leave-one-out" in ipaq.source and "leave-one-out" in n82.source
    assert get_profile("ipaq-hx2490b", "fixed16.16").cost == ipaq  # kept by with_()
