"""Structure specs: one grammar for every command, parsed and printed back the same."""
import pytest

from vismobile.partition.spec import format_spec, parse_spec


@pytest.mark.parametrize("text, parsed", [
    ("octree:5", ("octree", {"depth": 5})),
    ("grid:8", ("grid", {"slabs": 8})),
    ("grid:slabs=4x1x4", ("grid", {"slabs": (4, 1, 4)})),
    ("portal:2,cells=12", ("portal", {"depth": 2, "cells": 12})),
    ("bsp:min_leaf=4,seed=1", ("bsp", {"min_leaf": 4, "seed": 1})),
    ("BSP", ("bsp", {})),
    ("none", (None, {})),
])
def test_specs_parse_and_print_back(text, parsed):
    assert parse_spec(text) == parsed
    assert parse_spec(format_spec(*parsed)) == parsed


def test_the_main_parameter_prints_as_a_bare_number():
    assert format_spec("octree", {"depth": 5}) == "octree:5"
    assert format_spec("grid", {"auto": True}) == "grid:auto=True"


@pytest.mark.parametrize("text, message", [("cone:2", "unknown structure 'cone'"),
                                           ("octree:5,depth=4", "depth given twice")])
def test_bad_specs_say_what_is_wrong(text, message):
    with pytest.raises(ValueError, match=message):
        parse_spec(text)
