"""Key bindings: key names (pyglet's symbol strings, e.g. "UP", "W", "_1") to viewer actions.

HELD keys act while down (the thesis's joystick); PRESSED keys act once per press.
"""
from __future__ import annotations

HELD = {
    "UP": "forward", "W": "forward",
    "DOWN": "back", "S": "back",
    "LEFT": "turn_left", "A": "turn_left",
    "RIGHT": "turn_right", "D": "turn_right",
    "PAGEUP": "rise", "E": "rise",
    "PAGEDOWN": "sink", "Q": "sink",
    "HOME": "look_up", "END": "look_down",
}

# Number keys toggle stages in this order (0 is the tenth).
STAGE_KEYS = ("vfc", "bfc", "cbfc", "tbfc", "cone", "occlusion", "portals", "vfc_thesis",
              "cbfc_thesis", "occlusion_thesis")

PRESSED = {
    **{f"_{(i + 1) % 10}": f"toggle:{stage}" for i, stage in enumerate(STAGE_KEYS)},
    "TAB": "next_structure",
    "R": "record",            # start / stop recording the camera path
    "V": "save",              # save the recording (the project's trajectory CSV)
    "L": "load",              # load the trajectory file and play it back
    "P": "play",              # start / stop playback of the loaded trajectory
    "SPACE": "pause",
    "PERIOD": "step_forward",
    "COMMA": "step_back",
    "C": "show_culled",       # draw culled triangles in a second colour (x-ray)
    "B": "show_nodes",        # overlay the boxes of the drawn partition nodes
    "G": "god_view",          # god view: top, side, off
    "T": "lod_tau",           # level of detail: off, then tau 0.5, 1, 2, 4, 8 px
    "H": "toggle:horizon",    # the occlusion horizon (not a number key: they are all taken)
    "M": "terrain_method",    # a terrain's LOD method: tiles, roettger, roam
    "F1": "help",
    "F12": "screenshot",      # the view as PNG (vismobile-NNN.png beside the recording)
    "K": "screenshot",
    "ESCAPE": "quit",
}

# One line per binding for the help panel and the README.
# Lines of at most HELP_WIDTH characters, so that the side panel never wraps them.
HELP_WIDTH = 46
HELP = [
    "Up/W Down/S  forward/back (tap: one step)",
    "Left/A Right/D  turn    PgUp/E PgDn/Q  height",
    "Home/End  look up/down  drag  mouse look",
    *("  ".join(f"{(i + 1) % 10}:{STAGE_KEYS[i]:<16}" for i in (j, j + 1)
                if i < len(STAGE_KEYS)).rstrip()
      for j in range(0, len(STAGE_KEYS), 2)),
    "Tab  next structure   C  culled tint",
    "H  horizon (occlusion over ground solids)",
    "B  node boxes   G  god view (top/side/off)",
    "T  level of detail: off, tau 0.5 1 2 4 8 px",
    "M  terrain method: tiles, roettger, roam",
    "R  record on/off   V  save   L  load + play",
    "P  play/stop   Space  pause   . ,  step",
    "K/F12  screenshot   F1  help   Esc  quit",
]


def action_held(name: str):
    """The held action of a key name, or None."""
    return HELD.get(name.upper())


def action_pressed(name: str):
    """The one-shot action of a key name, or None."""
    return PRESSED.get(name.upper())


def parse_script(text: str) -> list:
    """Scripted key presses for tests and demos: "UP*10,_6,LEFT*3,WAIT*5" holds UP for 10
    frames, taps 6, holds LEFT for 3, then lets 5 frames pass. Returns [(frame, "down" or
    "up", key name)], sorted by frame; a tap goes down and up in one frame. ValueError on an
    unknown key or a bad count."""
    events, frame = [], 0
    for token in filter(None, (t.strip() for t in str(text).split(","))):
        name, _, count = token.partition("*")
        name = name.upper()
        if name not in HELD and name not in PRESSED and name != "WAIT":
            raise ValueError(f"unknown key {name!r} in script {text!r}")
        if count and not (count.isdigit() and int(count) > 0):
            raise ValueError(f"bad repeat count {count!r} in script {text!r}")
        frames = int(count or 1)
        if name == "WAIT":
            frame += frames
            continue
        events.append((frame, "down", name))
        events.append((frame + frames if count else frame, "up", name))
        frame += frames
    return events
