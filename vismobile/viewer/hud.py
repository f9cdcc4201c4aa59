"""The HUD of the thesis's runtime (SPEC §1) with the viewer's additions: one text line each."""
from __future__ import annotations

from ..device.costmodel import label

MB = 1 << 20


def hud_lines(info: dict) -> list:
    """Text lines from one frame's figures.

    info keys: stages (tuple), structure, sent, total, nodes_visited, cull_ms, render_ms
    (measured on this machine), device_fps (device model, None without one), profile,
    memory_bytes, heap_bytes, frame, mode ("fly", "play", "pause"), recording (bool),
    recorded (poses),
    waypoint ((label, offset) or None), message; an animated scene's moving (objects),
    moving_sent (of them sent this frame), time (s), pose_ms (their vertex upload).
    """
    stages = "+".join(s.upper() for s in info["stages"]) or "no culling"
    frame_ms = info["cull_ms"] + info["render_ms"]
    fps = 1000.0 / frame_ms if frame_ms > 0 else float("inf")
    device = (f"{info['device_fps']:.1f} fps ({label(info['profile'])})"
              if info.get("device_fps") is not None else f"{info['profile']}: no device model")
    share = 100.0 * info["sent"] / max(info["total"], 1)
    memory, heap = info["memory_bytes"], info["heap_bytes"]
    lines = [
        f"{stages}  /  {info['structure']}",
        f"sent {info['sent']:,} / {info['total']:,} tris ({share:.1f}%)",
        f"nodes visited {info['nodes_visited']:,}",
        f"cull {info['cull_ms']:.2f} ms  render {info['render_ms']:.2f} ms  ({fps:.0f} fps here)",
        device,
        f"mem {memory / MB:.1f} / {heap / MB:.0f} MB heap",  # the session refuses more
        _frame_line(info),
    ]
    if info.get("lod_tau") is not None:
        lines.insert(2, f"LOD tau {info['lod_tau']:g} px: {info['lod_full']:,} tris at full "
                        f"detail, {info['lod_coarse']} objects coarser")
    if info.get("moving") is not None:  # an animated scene (issue 25)
        lines.insert(2, f"moving {info['moving']:,} objects, {info['moving_sent']:,} sent  "
                        f"t {info['time']:.2f} s  pose {info['pose_ms']:.2f} ms")
    if info.get("message"):
        lines.append(info["message"])
    return lines


def _frame_line(info) -> str:
    mode = info["mode"]
    text = f"frame {info['frame']}  {mode}"
    if info.get("recording") or info.get("recorded"):
        text += f"  {'REC' if info.get('recording') else 'recorded'} {info['recorded']} poses"
    waypoint = info.get("waypoint")
    if waypoint is not None and mode in ("play", "pause"):
        label, offset = waypoint
        text += f"  waypoint {label} " + ("here" if offset == 0 else
                                          f"{offset} frames ago" if offset > 0 else
                                          f"in {-offset} frames")
    return text
