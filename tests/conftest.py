"""Session fixtures shared by all tests: the thesis worlds, built once and cached in worlds/."""
import pytest
from hypothesis import settings

# Property tests draw the same examples on every run, so CI is reproducible.
settings.register_profile("vismobile", derandomize=True, deadline=None)
settings.load_profile("vismobile")

from vismobile.scenes import build_world


@pytest.fixture(scope="session")
def thesis_world():
    """Factory: thesis_world("w2") -> World, cached per session and on disk in worlds/."""
    cache = {}

    def get(name: str):
        if name not in cache:
            cache[name] = build_world(name)
        return cache[name]

    return get


@pytest.fixture(scope="session")
def w1(thesis_world):
    return thesis_world("w1")


@pytest.fixture(scope="session")
def w5(thesis_world):
    return thesis_world("w5")
