"""Regional culling (issue 25): per region of the eye, the cheapest of several stage sets.

A hybrid world wants different culling in different places: inside a building the portals cut
the view at each doorway, outside in the streets they open on everything and occlusion (or a
baked PVS) does better. RegionalCuller holds one Culler per choice over the same partition;
a region is the portal cell holding the eye (partition extras cell_bounds; the grid cell of
the tree's level 1 otherwise; -1 outside them all). The first `probes` frames in a region cull
with every choice and price each result on a device model (device/costmodel.py: cull ms from
the counters plus render ms from triangles sent and draw calls, so the choice is the same on
any machine); after that the region keeps the choice with the lowest mean price. Every choice
is a conservative stage set, so whichever is picked, nothing visible is dropped.
"""
from __future__ import annotations

import numpy as np

from ..device.costmodel import device_counters, device_model
from ..geometry.boxes import boxes_contain_point

DEVICE = "ipaq-hx2490b"
CHOICES = ("portals+tbfc", "vfc+occlusion+tbfc")


class RegionalCuller:
    """Culler-compatible: `cull(camera, time=None)` -> the region's chosen Culler's result,
    with stats "regional.region" (cell id) and "active_stages" (the choice's stage string).

    partition : a Partition (or AnimatedPartition) every choice can cull
    choices   : stage strings (Culler's syntax), each conservative
    device    : device profile whose cost model prices a frame
    probes    : frames per region culled with every choice before the region decides
    culler_factory : callable(partition, stages) -> Culler
    decisions : {region: index of the choice} once decided
    """

    def __init__(self, partition, choices=CHOICES, device: str = DEVICE, probes: int = 2,
                 culler_factory=None):
        if culler_factory is None:
            from . import Culler as culler_factory
        if not choices:
            raise ValueError("regional culling needs at least one choice of stages")
        self.partition = partition
        self.choices = tuple(choices)
        self.cullers = [culler_factory(partition, stages) for stages in self.choices]
        self.model = device_model(device)
        self.probes = max(int(probes), 1)
        self.tree = self.cullers[0].tree
        extras = getattr(self.tree.partition, "extras", None) or {}
        self.regions = np.asarray(extras["cell_bounds"], dtype=np.float64) \
            if "cell_bounds" in extras else np.zeros((0, 2, 3))
        self.prices = {}  # region -> (choices, probes so far) list of modelled ms
        self.decisions = {}

    @property
    def cull_back(self) -> bool:
        return self.cullers[0].cull_back

    @property
    def names(self) -> tuple:
        return tuple(dict.fromkeys(n for c in self.cullers for n in c.names))

    def region_of(self, eye) -> int:
        """The first portal cell holding the eye (closed boxes), or -1."""
        inside = np.flatnonzero(boxes_contain_point(self.regions, eye))
        return int(inside[0]) if len(inside) else -1

    def price(self, result) -> float:
        """Modelled frame ms of a result on the device (cull + render)."""
        return self.model.frame_ms(device_counters(result, self.tree))

    def _cull(self, index, camera, time):
        culler = self.cullers[index]
        return culler.cull(camera) if time is None else culler.cull(camera, time=time)

    def cull(self, camera, time=None):
        region = self.region_of(camera.eye)
        if region in self.decisions:
            pick = self.decisions[region]
            result = self._cull(pick, camera, time)
        else:
            results = [self._cull(k, camera, time) for k in range(len(self.cullers))]
            prices = [self.price(r) for r in results]
            history = self.prices.setdefault(region, [])
            history.append(prices)
            pick = int(np.argmin(prices))
            if len(history) >= self.probes:
                self.decisions[region] = int(np.argmin(np.mean(history, axis=0)))
            result = results[pick]
            # what probing cost: the other choices' culls (modelled, like the frame's own)
            result.stats["regional.probe_ms"] = sum(
                self.model.cull_ms(device_counters(r, self.tree)) for k, r in enumerate(results)
                if k != pick)
        result.stats["regional.region"] = region
        result.stats["active_stages"] = self.choices[pick]
        return result
