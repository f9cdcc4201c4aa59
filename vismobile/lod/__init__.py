"""Level of detail for objects: chains built offline, levels selected per frame by projected
error in pixels among what culling kept (docs/lod.md)."""
from .chains import LodChains, render_world
from .image_error import image_error
from .select import LodSelector, Selection

__all__ = ["LodChains", "LodSelector", "Selection", "image_error", "render_world"]
