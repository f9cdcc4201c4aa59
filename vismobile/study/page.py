"""The HTML pieces every report page shares: its style sheet, numbers as text, and tables."""
from __future__ import annotations

import html
import math


STYLE = """body{font-family:sans-serif;max-width:1150px;margin:1.5em auto;color:#222}
table{border-collapse:collapse;margin:.6em 0;font-size:90%}td,th{border:1px solid #bbb;
padding:3px 7px;text-align:right;vertical-align:top}th{background:#eee}
td.l,th.l{text-align:left}img{max-width:100%}
pre{background:#f6f6f6;padding:8px;white-space:pre-wrap;overflow-wrap:anywhere;font-size:85%}
.note{color:#555;font-size:90%}tr.here td{color:#555}nav a{margin-right:1em}
h2{margin-top:1.6em;border-bottom:2px solid #ccc}"""


def _fmt(value, digits=1) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, float):
        return f"{value:,.{digits}f}"
    return html.escape(str(value))


def _table(header, rows, left=1, row_class=None) -> str:
    head = "".join(f"<th class='{'l' if i < left else ''}'>{html.escape(h)}</th>"
                   for i, h in enumerate(header))
    body = "".join(
        f"<tr class='{(row_class or [''] * len(rows))[k]}'>"
        + "".join(f"<td class='{'l' if i < left else ''}'>{cell}</td>"
                  for i, cell in enumerate(row)) + "</tr>" for k, row in enumerate(rows))
    return f"<table><tr>{head}</tr>{body}</table>"
