"""The comparison matrix: expand a selection (worlds, structures, culling, profiles) into run specs.

A selection reads like the CLI: `--worlds w1,w2 --structures grid,octree:3-6,portal:1-3,bsp
--cull all --profiles ipaq-hx2490b,nokia-n82 --frames sample:60`. Each RunSpec is one world on
its trajectory, one structure with its parameters, one culling combination and one profile.
"""
from __future__ import annotations

import hashlib
import json
import re
from dataclasses import asdict, dataclass

from ..errors import VisMobileError
from ..culling import BACKFACE_STAGES
from .thesis import NAMED_WORLDS, WORLDS, trajectory_for

# The thesis's 8 combinations (SPEC §6), in its order.
THESIS_CULLS = ("none", "bfc", "cbfc", "bfc+cbfc", "vfc", "vfc+bfc", "vfc+cbfc", "vfc+bfc+cbfc")
# Ours: stages the thesis left out or did not measure (occlusion that pays, normal cones,
# cells and portals) and the thesis's own loose variants, measured for their error.
OUR_CULLS = (
    "vfc+occlusion",
    "vfc+bfc+occlusion",
    "vfc+bfc+cbfc+occlusion",
    "vfc+bfc+tbfc",
    "vfc+bfc+tbfc+occlusion",
    "vfc+bfc+tbfc+occlusion+portals",
    "vfc+cone",
    "vfc+bfc+cone",
    "vfc+bfc+cbfc+cone+occlusion",
    "vfc+bfc+tbfc+horizon",                  # the 2.5D horizon: object worlds' ground occluders
    "vfc+portals",                           # the portals stage: portal structure only
    "vfc+bfc+cbfc+portals",
    "vfc+bfc+cbfc+occlusion+portals",
    "vfc+bfc+cbfc+occlusion_thesis",
    "vfc_thesis+bfc+cbfc",
    "vfc+bfc+cbfc_thesis",                   # the thesis's 2D backface rule, as it wrote it
)
# The order stages are written in a combination's label (labels key caches and reports: keep it).
STAGE_ORDER = ("vfc", "vfc_thesis", "bfc", "cbfc", "cbfc_thesis", "cone", "tbfc", "occlusion",
               "occlusion_thesis", "portals", "pvs", "horizon")
# The thesis's own variants, which it says may drop visible geometry: measured for their error
# and never tune candidates, even those our tests prove conservative (vfc_thesis, occlusion_thesis).
LOOSE_STAGES = ("vfc_thesis", "occlusion_thesis", "cbfc_thesis")
STRUCTURE_KINDS = ("grid", "octree", "portal", "bsp", "kdtree")
DEPTH_RANGE = {"octree": (1, 8), "portal": (1, 3)}
PROFILES = ("ipaq-hx2490b", "nokia-n82", "desktop")


class SelectionError(VisMobileError):
    """A compare/tune selection that cannot be expanded."""


@dataclass(frozen=True)
class RunSpec:
    """One run: a world on a trajectory, a structure, a culling combination and a profile.

    structure : canonical label, "grid", "octree:5", "portal:2", "bsp" or "kdtree", with a
                baked PVS "+pvs" (conservative) or "+pvs=sampled:N" ("portal:2+pvs")
    cull      : canonical stage list joined by '+', or "none"
    frames    : "all", "stride:N" or "sample:N" (N evenly spaced frames plus the waypoints)
    lod_tau   : level of detail at this many pixels of error (docs/lod.md), None: none
    """

    world: str
    trajectory: str
    structure: str
    cull: str
    profile: str
    frames: str = "all"
    lod_tau: float | None = None

    @property
    def kind(self) -> str:
        return self.structure.split("+")[0].split(":")[0]

    @property
    def params(self) -> dict:
        return structure_params(self.structure)

    @property
    def stages(self) -> tuple:
        return cull_stages(self.cull)

    @property
    def cull_back(self) -> bool:
        """True when the driver's back-face culling is on (the render flag)."""
        return "bfc" in self.stages

    @property
    def truth_cull_back(self) -> bool:
        """True when the ground truth is the back-face-culled item buffer."""
        return any(stage in BACKFACE_STAGES for stage in self.stages)

    def to_dict(self) -> dict:
        """The fields; lod_tau only when set, so runs without LOD keep their keys."""
        fields = asdict(self)
        if fields["lod_tau"] is None:
            del fields["lod_tau"]
        return fields

    def key(self, salt: str = "") -> str:
        """16 hex digits naming this run's result file; salt binds it to world/trajectory bytes."""
        text = json.dumps(self.to_dict(), sort_keys=True) + salt
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def structure_params(label: str) -> dict:
    """Partition parameters of a structure label: {} or {"depth": n} or {"auto": True}, plus
    {"pvs": "conservative"} or {"pvs": "sampled:N"} for a "+pvs" label."""
    label, _, pvs = label.partition("+")
    kind, _, depth = label.partition(":")
    params = {"auto": True} if kind == "grid" else \
        {"depth": int(depth)} if kind in ("octree", "portal") else {}
    if pvs:
        params["pvs"] = pvs.partition("=")[2] or "conservative"
    return params


def pvs_of(label: str) -> str | None:
    """The PVS mode of a structure label ("conservative", "sampled:N") or None."""
    return structure_params(label).get("pvs")


def base_structure(label: str) -> str:
    """The label without its PVS ("portal:2+pvs" -> "portal:2")."""
    return label.partition("+")[0]


def cull_stages(cull: str) -> tuple:
    """The stage names of a combination, "none" -> ()."""
    return () if cull == "none" else tuple(cull.split("+"))


def canonical_cull(text: str) -> str:
    """Stage list in STAGE_ORDER order, joined by '+'; raises SelectionError for unknown stages."""
    text = text.strip().lower()
    if text in ("", "none"):
        return "none"
    parts = [part.strip() for part in text.split("+") if part.strip()]
    unknown = [part for part in parts if part not in STAGE_ORDER]
    if unknown:
        raise SelectionError(f"unknown culling stage {unknown[0]!r}; known: {', '.join(STAGE_ORDER)}")
    if "vfc" in parts and "vfc_thesis" in parts:
        raise SelectionError("choose one of vfc and vfc_thesis, not both")
    return "+".join(stage for stage in STAGE_ORDER if stage in parts)


# A structure item: kind, optional depth or depth range, optional baked PVS (+pvs: conservative).
STRUCTURE_ITEM = re.compile(r"(grid|octree|portal|bsp|kdtree)(?::(\d+)(?:-(\d+))?)?"
                            r"(\+pvs(?:=(conservative|sampled:([1-9]\d{0,3})))?)?")
MAX_PVS_SAMPLES = 4096  # pvs=sampled:N, N points per view cell (each six item buffers)


def parse_structures(text: str) -> list:
    """'grid,octree:3-6,portal:1-3,bsp' -> ['grid', 'octree:3', ..., 'portal:3', 'bsp'];
    a '+pvs' suffix ('portal:2+pvs', 'bsp+pvs=sampled:64') bakes a PVS on each structure
    (conservative unless sampled:N is given; canonical labels end in '+pvs' or
    '+pvs=sampled:N')."""
    labels = []
    for item in filter(None, (part.strip().lower() for part in text.split(","))):
        if item == "all":
            labels += parse_structures("grid,octree:3-6,portal:1-3,bsp")
            continue
        match = STRUCTURE_ITEM.fullmatch(item)
        if not match:
            raise SelectionError(f"bad structure {item[:60]!r}: use grid, octree:N, octree:A-B, "
                                 "portal:N, bsp or kdtree, optionally +pvs or "
                                 "+pvs=sampled:N (a baked PVS)")
        kind, low, high, pvs, mode, samples = match.groups()
        suffix = "" if not pvs else \
            "+pvs" if mode in (None, "conservative") else f"+pvs=sampled:{int(samples)}"
        if samples is not None and not 1 <= int(samples) <= MAX_PVS_SAMPLES:
            raise SelectionError(f"{item!r}: sampled:N takes 1..{MAX_PVS_SAMPLES} points")
        if kind in ("grid", "bsp", "kdtree"):
            if low is not None:
                raise SelectionError(f"{kind} takes no depth (got {item!r})")
            labels.append(kind + suffix)
            continue
        low = int(low) if low is not None else (5 if kind == "octree" else 2)
        high = int(high) if high is not None else low
        lowest, highest = DEPTH_RANGE[kind]
        if not lowest <= low <= high <= highest:
            raise SelectionError(f"{kind} depth must be {lowest}..{highest} (got {item!r})")
        labels += [f"{kind}:{depth}{suffix}" for depth in range(low, high + 1)]
    return list(dict.fromkeys(labels))


def cull_items(text) -> list:
    """The combinations of a --cull list: items separated by ';' or whitespace (or, the older
    form, ','); a list or tuple (repeated --cull options) is split item by item."""
    if isinstance(text, (list, tuple)):
        return [item for part in text for item in cull_items(part)]
    return [part for part in re.split(r"[;,\s]+", str(text).strip().lower()) if part]


def ambiguous_commas(text) -> str | None:
    """A note when a --cull list uses ',' between single stages ('vfc,bfc'): in compare that is
    two combinations, in play and view one; None when the text has no such comma."""
    parts = [text] if isinstance(text, str) else list(text)
    for part in parts:
        items = [i.strip().lower() for i in str(part).split(",") if i.strip()]
        singles = [i for i in items if i in STAGE_ORDER]
        if len(items) > 1 and singles:
            return (f"--cull {part}: ',' separates combinations in compare ({len(items)} of "
                    f"them: {'; '.join(items)}); to run stages together join them with + "
                    f"({'+'.join(items)}); list combinations with ';' or repeated --cull")
    return None


def parse_culls(text) -> list:
    """'all' | 'thesis' | 'ours' | 'vfc+cbfc;none' (or a list of such) -> canonical combination
    labels; items as cull_items splits them."""
    culls = []
    for item in cull_items(text):
        if item in ("all", "thesis"):
            culls += THESIS_CULLS
        if item in ("all", "ours"):
            culls += OUR_CULLS
        if item not in ("all", "thesis", "ours"):
            culls.append(canonical_cull(item))
    return list(dict.fromkeys(culls))


def parse_worlds(text: str) -> list:
    """'w1,w3', 'all' or mesh file paths ('room.obj,w5') -> world names and paths, in order;
    SelectionError on anything else (a path must name an existing file)."""
    from pathlib import Path

    worlds = []
    for item in filter(None, (part.strip() for part in text.split(","))):
        if item.lower() == "all":
            worlds += WORLDS
        elif item.lower() in NAMED_WORLDS:
            worlds.append(item.lower())
        elif Path(item).is_file():
            worlds.append(item)
        else:
            raise SelectionError(f"unknown world {item!r}: not {', '.join(NAMED_WORLDS)}, all, "
                                 "or an existing mesh file")
    return list(dict.fromkeys(worlds))


def parse_profiles(text: str) -> list:
    """'ipaq-hx2490b,nokia-n82' -> profile names; SelectionError on an unknown one."""
    profiles = [part.strip().lower() for part in text.split(",") if part.strip()]
    for name in profiles:
        if name not in PROFILES:
            raise SelectionError(f"unknown profile {name!r}; known: {', '.join(PROFILES)}")
    return list(dict.fromkeys(profiles))


def parse_frames(text: str) -> str:
    """Canonical frame selection: "all", "stride:N" or "sample:N"; SelectionError otherwise."""
    from ..world.trajectory import MAX_FRAMES

    text = text.strip().lower()
    match = re.fullmatch(r"(stride|sample):([1-9]\d{0,8})", text)
    if text == "all" or (match and int(match[2]) <= MAX_FRAMES):
        return text
    raise SelectionError(f"bad frame selection {text[:40]!r}: use all, stride:N or sample:N "
                         f"with N from 1 to {MAX_FRAMES:,}")


def parse_lod(text) -> list:
    """'none,1,2' -> [None, 1.0, 2.0]: level-of-detail tolerances in pixels (none: no LOD)."""
    taus = []
    for item in str(text or "none").split(","):
        item = item.strip().lower()
        if item in ("", "none", "off"):
            taus.append(None)
            continue
        try:
            tau = float(item)
        except ValueError:
            tau = float("nan")
        if not 0.0 <= tau < 1e6:
            raise SelectionError(f"--lod {item!r}: a tolerance in pixels >= 0, or none")
        taus.append(tau)
    return list(dict.fromkeys(taus))


def expand(worlds="all", structures="all", culls="all", profiles="ipaq-hx2490b",
           frames="all", trajectories=None, lod="none") -> list:
    """Every RunSpec of a selection, in a stable order (world, structure, cull, profile).

    Combinations that cannot run are left out: `portals` only on the portal structure, `pvs`
    only on a structure with a baked PVS ("+pvs"); on such a structure every combination runs
    with `pvs` added (with_pvs), so `--structures portal:2,portal:2+pvs --cull vfc+tbfc` sets
    vfc+tbfc beside pvs+vfc+tbfc.
    trajectories : optional {world: path} overriding the thesis's indoor/outdoor paths; a world
                   given as a file needs one.
    lod          : level-of-detail tolerances, 'none,1,2' (parse_lod): one run per tolerance
    """
    trajectories = trajectories or {}
    frames = parse_frames(frames)
    specs = []
    for world in parse_worlds(worlds):
        if world not in trajectories and world not in NAMED_WORLDS:
            raise SelectionError(f"{world}: no trajectory for a world file; pass --trajectory "
                                 "CSV (vismobile trajectory generate WORLD makes one)")
        path = trajectories.get(world) or trajectory_for(world)
        for structure in parse_structures(structures):
            for cull in dict.fromkeys(with_pvs(c, structure) for c in parse_culls(culls)):
                if not runs_on(cull, structure):
                    continue
                for profile in parse_profiles(profiles):
                    for tau in parse_lod(lod):
                        specs.append(RunSpec(world, str(path), structure, cull, profile, frames,
                                             tau))
    if not specs:
        raise SelectionError("the selection is empty")
    return specs


def with_pvs(cull: str, structure: str) -> str:
    """The combination as it runs on a structure: `pvs` added when the structure has a PVS."""
    if pvs_of(structure) is None or "pvs" in cull_stages(cull):
        return cull
    return canonical_cull("+".join(cull_stages(cull) + ("pvs",)))


def runs_on(cull: str, structure: str) -> bool:
    """Whether a combination runs on a structure label: `portals` needs the portal structure,
    `pvs` a baked PVS, and a structure with one runs only combinations with `pvs` (without
    it, it is its base structure)."""
    stages = cull_stages(cull)
    if "portals" in stages and not structure.startswith("portal"):
        return False
    return ("pvs" in stages) == (pvs_of(structure) is not None)


def frame_indices(selection: str, count: int, waypoints: dict) -> list:
    """Frame numbers of a selection over a trajectory of `count` frames (sorted, unique)."""
    from ..world.trajectory import select_frames

    return select_frames(selection, count, waypoints)
