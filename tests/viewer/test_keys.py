import pytest

from vismobile.viewer.keys import HELD, PRESSED, STAGE_KEYS, action_held, action_pressed, parse_script
from vismobile.culling import STAGES


def test_thesis_joystick_and_toggles():
    assert action_held("up") == "forward" and action_held("LEFT") == "turn_left"
    assert action_held("PAGEUP") == "rise" and action_held("PAGEDOWN") == "sink"
    assert action_pressed("_1") == "toggle:vfc" and action_pressed("_0") == "toggle:occlusion_thesis"
    assert set(STAGE_KEYS) <= set(STAGES)
    assert not set(HELD) & set(PRESSED)


def test_parse_script():
    assert parse_script("UP*3, _6,left*2") == [
        (0, "down", "UP"), (3, "up", "UP"), (3, "down", "_6"), (3, "up", "_6"),
        (4, "down", "LEFT"), (6, "up", "LEFT")]
    assert parse_script("") == []
    assert parse_script("WAIT*4,R") == [(4, "down", "R"), (4, "up", "R")]
    for bad in ("NOPE", "UP*0", "UP*x"):
        with pytest.raises(ValueError):
            parse_script(bad)
