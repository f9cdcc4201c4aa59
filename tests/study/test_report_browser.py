"""The report in a real browser: headless Debian chromium renders it without errors, every
figure in the page loads, and no figure has overprinted tick labels or data squashed into under
10% of its height (each <img>'s data-layout, plots.layout_problems). Skipped (with the reason) where chromium is not installed; `make test`
installs it where it can (root with apt-get), so CI runs it."""
import json
import re

import numpy as np
import pytest

from vismobile.study import browser
from vismobile.study.report import write_report

pytestmark = pytest.mark.skipif(
    browser.chromium() is None,
    reason="Debian's chromium is not installed; `make test` installs it as root with apt-get")

# Injected into a copy of the report (the report itself has no scripts): records script errors
# and, once loaded, every image's state, into an attribute --dump-dom prints.
CHECKER = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(String(e.message || e.type)), true);
window.addEventListener('load', () => {
  const images = Array.from(document.images).map(i => ({alt: i.alt,
      ok: i.complete && i.naturalWidth > 0, width: i.naturalWidth,
      layout: JSON.parse(i.dataset.layout || '["no layout record"]')}));
  document.documentElement.setAttribute('data-check',
      JSON.stringify({errors: window.__errors, images: images,
                      tables: document.querySelectorAll('table').length}));
});
</script>"""


BROKEN = "a broken figure (the check must see it)"


def broken_figure() -> str:
    """<img> of a figure with both faults: overprinted y tick labels, data in a thin band."""
    from vismobile.study.plots import figure_png, pyplot

    fig, ax = pyplot().subplots(figsize=(6, 2))
    ax.plot(np.arange(50), 1000 + np.sin(np.arange(50)))
    ax.set_ylim(900, 5000)
    ax.set_yticks(np.linspace(900, 5000, 40))
    return figure_png(fig, BROKEN)


@pytest.fixture(scope="module")
def page(study, tmp_path_factory):
    _, _, records = study
    folder = tmp_path_factory.mktemp("browser")
    report = write_report(records, folder / "report.html")
    text = report.read_text()
    checked = folder / "checked.html"
    # the checked copy ends with one broken figure, which the check must report
    checked.write_text(text.replace("<head>", "<head>" + CHECKER, 1)
                       .replace("</body>", broken_figure() + "</body>", 1))
    return report, text, checked


def test_the_report_renders_without_errors_with_every_figure(page):
    _, text, checked = page
    dom = browser.dump_dom(checked)
    match = re.search(r'data-check="([^"]*)"', dom)
    assert match, "the page did not finish loading in chromium"
    check = json.loads(match.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert check["errors"] == []
    expected = re.findall(r"<img class='fig' alt='([^']*)'", text)
    broken = check["images"].pop()
    assert [image["alt"] for image in check["images"]] == expected
    assert all(image["ok"] and image["width"] > 100 for image in check["images"])
    # No overprinted tick labels, no data squashed against an edge, in any report figure ...
    assert {image["alt"]: image["layout"] for image in check["images"] if image["layout"]} == {}
    # ... and the check sees both faults when they are there.
    assert broken["alt"] == BROKEN and broken["ok"]
    assert any("tick labels" in p for p in broken["layout"]), broken["layout"]
    assert any("of its height" in p for p in broken["layout"]), broken["layout"]
    # Each world's first figures: along the path, triangles sent, run time against error.
    world = "TINY"
    for alt in (f"{world} ms per frame along the path", f"{world} triangles sent",
                f"{world} run time against error"):
        assert alt in expected
    assert check["tables"] >= 2


def test_the_first_screen_is_drawn(page, tmp_path):
    from PIL import Image

    report, _, _ = page
    png = browser.screenshot(report, tmp_path / "first.png", 1000, 700)
    pixels = np.asarray(Image.open(png).convert("L"))
    assert pixels.shape == (700, 1000)
    # Text and table rules: a good share of the first screen is not background.
    assert (pixels < 200).mean() > 0.01
