"""Heightmap terrain worlds (seeds 000-003): samples, files, meshes and their LOD methods."""
