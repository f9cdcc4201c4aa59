"""The scene model: the triangle world, the camera, trajectories, winding checks and worlds
mapped from disk."""
from .world import World

__all__ = ["World"]
