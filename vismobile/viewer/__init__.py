"""The interactive viewer (thesis §1's runtime with its joystick, HUD and trajectory menu).

session.Session holds every piece of state and logic and renders frames as arrays, so it runs
and is tested without a window; window.py (pyglet, imported only by `vismobile view`) shows
them. keys.py: the bindings; controls.py: the joystick; recorder.py: record, save, load and
play back trajectories; hud.py: the HUD text; godview.py: the side/top view; layout.py: where
each panel goes in the window.
"""
from .session import Session

__all__ = ["Session"]
