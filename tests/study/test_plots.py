"""The report's figures are readable: plots.layout_problems finds overprinted tick labels and
data squashed into a thin band, and no figure of a report has either."""
import json
import re

import numpy as np

from vismobile.study.plots import layout_problems, log_axis, pyplot
from vismobile.study.report import write_report


def figure(height=3.2):
    return pyplot().subplots(figsize=(8, height))


def test_a_readable_figure_has_no_problems():
    fig, ax = figure()
    x = np.arange(200)
    ax.plot(x, 2000 + 1500 * np.sin(x / 9), label="sent")
    ax.axhline(6199, color="k")  # a reference line is not data
    log_axis(ax, "y")
    assert layout_problems(fig) == []
    pyplot().close(fig)


def test_a_constant_series_on_an_axis_from_zero_is_readable():
    """A device model's constant frame time: a flat line, read from the axis's 0 like a bar."""
    fig, ax = figure()
    ax.plot(np.arange(8), np.full(8, 91.0))
    ax.set_ylim(bottom=0)
    assert layout_problems(fig) == []
    ax.set_ylim(80, 100)  # the same line with no baseline: a thin band
    assert len(layout_problems(fig)) == 1
    pyplot().close(fig)


def test_overprinted_tick_labels_are_found():
    fig, ax = figure(1.5)
    ax.plot(np.arange(10), np.arange(10) * 100.0)
    ax.set_yticks(np.linspace(0, 900, 40))
    problems = layout_problems(fig)
    assert problems and all("y tick labels" in p for p in problems)
    pyplot().close(fig)


def test_data_squashed_against_an_edge_are_found():
    fig, ax = figure()
    x = np.arange(100)
    ax.plot(x, 5000 + 20 * np.sin(x))        # W1's sent triangles under a far headroom
    ax.set_ylim(top=6199 * 4)
    log_axis(ax, "y")
    problems = layout_problems(fig)
    assert len(problems) == 1 and "of its height (under 10%)" in problems[0], problems
    pyplot().close(fig)


def test_no_figure_of_the_report_is_unreadable(study, tmp_path):
    _, _, records = study
    text = write_report(records, tmp_path / "report.html").read_text()
    layouts = re.findall(r"<img class='fig' alt='([^']*)' data-layout='([^']*)'", text)
    assert len(layouts) >= 3
    bad = {alt: json.loads(record.replace("&quot;", '"')) for alt, record in layouts
           if record != "[]"}
    assert bad == {}
