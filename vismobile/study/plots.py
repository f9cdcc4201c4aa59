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
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:,.4g}"))
    axis.set_minor_locator(ticker.LogLocator(base=10, subs=np.arange(1, 10)))
    axis.set_minor_formatter(ticker.NullFormatter())


def waypoints(ax, marks: dict) -> None:
    """Dashed vertical lines at the waypoint frames, their letters inside the top of the axes."""
    for letter, frame in marks.items():
        ax.axvline(frame, color="#888", lw=0.7, ls="--", zorder=0)
        ax.text(frame, 0.97, letter, transform=ax.get_xaxis_transform(), ha="center",
                va="top", fontsize=8, color="#444",
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})


def figure_png(fig, alt: str) -> str:
    """<img> tag holding the figure as an inline PNG; closes the figure."""
    import html

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    pyplot().close(fig)
    return (f"<img class='fig' alt='{html.escape(alt, quote=True)}' "
            "src='data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")
            + "'>")
