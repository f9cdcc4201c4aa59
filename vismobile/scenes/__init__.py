"""Thesis world generator: the building (W1-W4), the city (W5-W6) and their objects."""
from .lookup import is_thesis_world, world_file
from .thesis import TARGETS, build_all, build_world, default_cache_dir, generate

__all__ = ["TARGETS", "build_all", "build_world", "default_cache_dir", "generate",
           "is_thesis_world", "world_file"]
