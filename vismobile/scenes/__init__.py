"""Thesis world generator: the building (W1-W4), the city (W5-W6) and their objects."""
from .thesis import TARGETS, build_all, build_world, default_cache_dir, generate

__all__ = ["TARGETS", "build_all", "build_world", "default_cache_dir", "generate"]
