"""Readable matplotlib figures for the report: one style per series, legends outside the data.

Every series gets its own colour and line style (a 10-colour qualitative palette crossed with
four line styles: 40 distinct series), legends sit right of the axes, every axis names its
unit, log axes get labelled ticks at 1, 2 and 5 per decade, and waypoint letters sit inside the
axes (never on the title). figure_png returns an <img> tag with the PNG inline.
"""
from __future__ import annotations

import base64
import io

import numpy as np

# matplotlib's tab10: a qualitative palette whose colours stay apart in print and for the
# common colour-vision deficiencies; crossed with line styles past ten series.
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#7f7f7f", "#bcbd22", "#17becf")
LINE_STYLES = ("-", "--", ":", "-.")
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def style(index: int) -> dict:
    """Line keyword arguments of series `index`: colour, line style and marker, all distinct
    for the first 40 series."""
    return {"color": PALETTE[index % len(PALETTE)],
            "linestyle": LINE_STYLES[(index // len(PALETTE)) % len(LINE_STYLES)],
            "marker": MARKERS[index % len(MARKERS)]}


def legend_outside(ax, title=None) -> None:
    """The axes' legend right of the plot area, so it never covers data."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
                  frameon=False, title=title, title_fontsize=8, borderaxespad=0.0)


def log_axis(ax, which="y") -> None:
    """Log scale with labelled ticks at 1, 2 and 5 per decade, more when the data spans less
    than a decade (plain numbers, no 10^k). Call it after plotting."""
    import matplotlib.ticker as ticker

    axis = ax.yaxis if which == "y" else ax.xaxis
    (ax.set_yscale if which == "y" else ax.set_xscale)("log")
    low, high = (ax.get_ylim if which == "y" else ax.get_xlim)()
    # Less than a decade of data: label more steps, so the axis still has several ticks.
    subs = (1.0, 2.0, 5.0) if high > 0 and low > 0 and high / low > 8 else \
        (1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.0)
    axis.set_major_locator(ticker.LogLocator(base=10, subs=subs))
    axis.set_major_formatter(ticker.FuncFormatter(
        lambda v, _: f"{v:,.0f}" if v >= 10 else f"{v:.4g}"))  # 100,000 rather than 1e+05
    axis.set_minor_locator(ticker.LogLocator(base=10, subs=np.arange(1, 10)))
    axis.set_minor_formatter(ticker.NullFormatter())


def waypoints(ax, marks: dict) -> None:
    """Dashed vertical lines at the waypoint frames, their letters inside the top of the axes."""
    for letter, frame in marks.items():
        ax.axvline(frame, color="#888", lw=0.7, ls="--", zorder=0)
        ax.text(frame, 0.97, letter, transform=ax.get_xaxis_transform(), ha="center",
                va="top", fontsize=8, color="#444",
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})


MIN_DATA_FILL = 0.10  # the plotted data must span at least this share of an axes' height
# Tick labels overlap when their boxes share more than this share of the smaller box: a text
# box holds the font's ascent and descent, so labels of digits may touch without any ink meeting.
LABEL_OVERLAP = 0.2


def _overlap(a, b) -> float:
    """Shared area of two matplotlib Bboxes over the smaller one's area."""
    width = min(a.x1, b.x1) - max(a.x0, b.x0)
    height = min(a.y1, b.y1) - max(a.y0, b.y0)
    if width <= 0 or height <= 0:
        return 0.0
    return width * height / max(min(a.width * a.height, b.width * b.height), 1e-9)


def layout_problems(fig, min_fill: float = MIN_DATA_FILL) -> list:
    """What makes the figure hard to read, from matplotlib's own layout (the PNG is drawn from
    it): tick labels of one axis that overlap (overprinted text: more than LABEL_OVERLAP of the
    smaller label's box), and axes whose data span less
    than min_fill of their height (lines squashed against an edge). Data are the plotted
    series (lines of two or more points, scatter points); reference lines spanning the axes
    (axhline, axvline) and text are not. A linear axis starting at 0 is read from 0, as bars
    are: a constant series at 90 ms on a 0..100 axis fills 90% of it. [] when readable."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    for number, ax in enumerate(fig.axes):
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            low, high = sorted(axis.get_view_interval())
            labels = [t for loc, t in zip(axis.get_majorticklocs(), axis.get_majorticklabels())
                      if low <= loc <= high and t.get_visible() and t.get_text()]
            boxes = [t.get_window_extent(renderer) for t in labels]
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    if _overlap(boxes[i], boxes[j]) > LABEL_OVERLAP:
                        problems.append(f"axes {number}: {name} tick labels "
                                        f"{labels[i].get_text()!r} and {labels[j].get_text()!r} "
                                        "overlap")
        ys = []
        for line in ax.get_lines():
            x, y = (np.asarray(v, dtype=float) for v in line.get_data())
            if line.get_visible() and y.size > 1 and line.get_transform() == ax.transData:
                ys.append(ax.transData.transform(np.c_[x, y])[:, 1])
        for points in ax.collections:
            offsets = points.get_offsets()
            if points.get_visible() and len(offsets):
                ys.append(points.get_offset_transform().transform(offsets)[:, 1])
        if ax.get_yscale() == "log" and min(ax.get_ylim()) <= 0:
            problems.append(f"axes {number}: a log y axis reaching {min(ax.get_ylim()):g} "
                            "(drawn from a tiny positive value: the data squashed at its top)")
            continue
        ys = [y[np.isfinite(y)] for y in ys]
        ys = [y for y in ys if y.size]
        if ys and ax.get_yscale() == "linear" and ax.get_ylim()[0] == 0:
            ys.append(ax.transData.transform([[0.0, 0.0]])[:, 1])  # the axis's own baseline
        if ys:
            low, high = ax.get_window_extent(renderer).intervaly
            drawn = np.clip(np.concatenate(ys), low, high)
            fill = (drawn.max() - drawn.min()) / max(high - low, 1e-9)
            if fill < min_fill:
                problems.append(f"axes {number}: the data span {fill:.0%} of its height "
                                f"(under {min_fill:.0%})")
    return problems


def figure_png(fig, alt: str) -> str:
    """<img> tag holding the figure as an inline PNG; closes the figure. Its data-layout
    attribute lists layout_problems (JSON, [] when readable) for the report's browser check."""
    import html
    import json

    problems = layout_problems(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    pyplot().close(fig)
    return (f"<img class='fig' alt='{html.escape(alt, quote=True)}' "
            f"data-layout='{html.escape(json.dumps(problems), quote=True)}' "
            "src='data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")
            + "'>")
