"""report.html: the diagnosis report as one self-contained HTML file.

The page is report.md's text rendered by ``markdown-it-py`` (CommonMark with tables; raw
HTML in the text is escaped, not passed through), with every figure embedded as a base64
PNG data URI and the style sheet inline. It needs no network and runs no script: it opens
the same from a mail attachment, an archive or an air-gapped machine. Using report.md's own
text means the two files cannot disagree.

:func:`correlation_figure` draws the named parameters' correlation matrix
(``identifiability.png``).
"""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from markdown_it import MarkdownIt
from matplotlib.figure import Figure

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; max-width: 80rem;
       margin: 2rem auto; padding: 0 1rem; line-height: 1.45; color: #1a1a1a; }
h1 { font-size: 1.5rem; } h2 { border-bottom: 1px solid #ddd; padding-bottom: .2rem; }
table { border-collapse: collapse; margin: .6rem 0; font-size: .9rem; }
th, td { border: 1px solid #ccc; padding: .25rem .5rem; text-align: left;
         vertical-align: top; }
th { background: #f3f3f3; }
img { max-width: 100%; height: auto; }
blockquote { border-left: 4px solid #e0a000; margin: .6rem 0; padding: .2rem .8rem;
             background: #fff8e6; }
code { background: #f3f3f3; padding: 0 .2rem; }
"""


def data_uri(png: bytes) -> str:
    """``data:image/png;base64,...`` for PNG bytes."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def html_page(data: dict[str, Any], pngs: Mapping[str, bytes],
              markdown: Callable[..., str]) -> str:
    """The complete report.html text.

    Args:
        data: the report dict to render (with fallbacks, as for report.md).
        pngs: figure file name -> PNG bytes; a figure that is missing (``--no-figures``)
            is replaced by a one-line note instead of a broken image.
        markdown: report.md's text builder, called as ``markdown(data)``; its image
            references (figure file names) are replaced by the embedded PNGs.
    """
    md = MarkdownIt("commonmark", {"html": False}).enable("table")
    # rendered with the plain file names (parsing a long data URI is slow), then swapped
    body = md.render(markdown(data))

    def embed(m: re.Match) -> str:
        name, alt = html.unescape(m.group(1)), m.group(2)
        if name in pngs:
            return f'<img src="{data_uri(pngs[name])}" alt="{alt}" />'
        return f"<em>(figure “{alt}” not written: the report was made without figures)</em>"

    body = re.sub(r'<img src="([^"]*)" alt="([^"]*)" ?/?>', embed, body)
    title = html.escape(f"simgap diagnosis: {data.get('recording', '')}")
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n{body}"
            "</body>\n</html>\n")


def correlation_figure(ident: Mapping[str, Any]) -> Figure:
    """Heat map of the named parameters' correlation matrix (a Figure, no pyplot state)."""
    names = [str(n) for n in ident["names"]]
    corr = np.asarray(ident["correlation"], dtype=float)
    n = len(names)
    size = min(12.0, 4.0 + 0.6 * n)
    fig = Figure(figsize=(size + 2.0, size), layout="constrained")
    ax = fig.subplots()
    im = ax.imshow(corr, vmin=-1.0, vmax=1.0, cmap="RdBu_r")
    ax.set_xticks(range(n), names, rotation=45, ha="right", fontsize=8)
    ax.set_yticks(range(n), names, fontsize=8)
    if n <= 12:
        for i in range(n):
            for j in range(n):
                if np.isfinite(corr[i, j]):
                    ax.text(j, i, f"{corr[i, j]:+.2f}", ha="center", va="center", fontsize=7,
                            color="white" if abs(corr[i, j]) > 0.6 else "black")
    fig.colorbar(im, ax=ax, label="correlation of the estimates (-)")
    cond = ident.get("condition")
    extra = f"\n(condition number {float(cond):.3g})" if isinstance(cond, (int, float)) \
        and np.isfinite(cond) else ""
    ax.set_title(f"Correlation of the named parameters{extra}")
    return fig
