"""Screenshot of a report's first screen in headless chromium (docs/report_first_screen.png).

    .venv/bin/python tools/report_screenshot.py [out/report/index.html] [--out PNG]

Run `make demo` first for out/report/index.html. Needs Debian's chromium (`make browser`).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv=None) -> int:
    from vismobile.study import browser

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("report", type=Path, nargs="?", default=Path("out/report/index.html"))
    parser.add_argument("--out", type=Path, default=Path("docs/report_first_screen.png"))
    parser.add_argument("--size", default="1280x900", help="window WIDTHxHEIGHT")
    args = parser.parse_args(argv)
    if not args.report.is_file():
        print(f"{args.report}: no such report (run make demo)", file=sys.stderr)
        return 2
    width, height = (int(v) for v in args.size.lower().split("x"))
    print(browser.screenshot(args.report, args.out, width, height))
    return 0


if __name__ == "__main__":
    sys.exit(main())
