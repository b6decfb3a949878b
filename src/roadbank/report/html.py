"""Markdown report -> one self-contained HTML page (markdown-it-py, CommonMark + tables).

Figures referenced by the markdown (``![alt](figures/x.png)``) are embedded as
data URIs, so the page can be mailed or moved alone; the style sheet keeps text
and summary tables within a laptop screen (about 1366 px) and lets a table wider
than the page scroll inside its own box instead of the page.
"""

from __future__ import annotations

import base64
import html
import mimetypes
from pathlib import Path
from urllib.parse import unquote, urlparse

from .markdown import Slugger

__all__ = ["md_to_html", "write_document", "STYLE"]

STYLE = """
body{font:15px/1.5 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#1d1d1f;
 max-width:88rem;margin:0 auto;padding:0.5rem 1rem 3rem}
h1{font-size:1.6rem;line-height:1.25}h2{font-size:1.25rem;margin-top:2.2rem;border-bottom:1px solid #ddd}
h3{font-size:1.05rem;margin-top:1.6rem}
p,li,h1{max-width:62rem}
code{font:0.88em ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;background:#f2f3f5;padding:0 0.2em;
 border-radius:3px}
.table{overflow-x:auto;margin:0.6rem 0 1rem}
table{border-collapse:collapse;font-size:12.5px;font-variant-numeric:tabular-nums}
th,td{border:1px solid #c9ccd1;padding:2px 5px;vertical-align:top}
th{background:#eef0f3;font-weight:600;text-align:left}
tbody tr:nth-child(even){background:#f8f9fa}
td[style*="right"]{white-space:nowrap}
td[style*="right"] strong{background:#d9f2e0;padding:0 0.25em;border-radius:2px}
img{max-width:100%;height:auto}
figure,p>img{display:block;margin:0.5rem 0}
"""


def _data_uri(path: Path) -> str:
    mime = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
    if path.suffix.lower() == ".svg":
        mime = "image/svg+xml"
    return f"data:{mime};base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _local(src: str) -> bool:
    u = urlparse(src)
    return not u.scheme and not u.netloc and not src.startswith("#")


def _plain(inline) -> str:
    """The text a heading shows (its inline token's text and code spans, markup dropped)."""
    return "".join(c.content for c in (inline.children or []) if c.type in ("text", "code_inline"))


def md_to_html(markdown: str, title: str | None = None, *, base_dir=None, embed: bool = True) -> str:
    """Render report markdown as one HTML page.

    Parameters
    ----------
    markdown : str
        CommonMark with GitHub-style tables (what :func:`roadbank.report.markdown.md_table` writes).
        Raw HTML in it is shown as text, not interpreted.
    title : str, optional
        The page title (default: the first heading, else "roadbank report").
    base_dir : path-like, optional
        Folder that relative image paths are resolved against (default: the current one).
    embed : bool
        Embed local images as base64 data URIs (default) instead of linking them.

    Every heading gets an ``id`` (:class:`roadbank.report.markdown.Slugger`: GitHub's
    anchors), so ``[text](#anchor)`` links of a contents list work in the page.

    Raises
    ------
    FileNotFoundError
        If a local image the markdown references does not exist (naming it).
    """
    from markdown_it import MarkdownIt      # deferred: `roadbank validate --help` imports this module

    base = Path(base_dir) if base_dir is not None else Path.cwd()
    md = MarkdownIt("commonmark", {"html": False, "typographer": False}).enable("table")

    def image(self, tokens, idx, options, env):
        tok = tokens[idx]
        src = tok.attrGet("src") or ""
        if _local(src):
            path = base / unquote(urlparse(src).path)
            if not path.is_file():
                raise FileNotFoundError(f"{path}: figure referenced by the report ('{src}') does not exist")
            if embed:
                tok.attrSet("src", _data_uri(path))
        return self.image(tokens, idx, options, env)

    md.add_render_rule("image", image)
    md.add_render_rule("table_open", lambda self, tokens, idx, options, env: '<div class="table">\n<table>\n')
    md.add_render_rule("table_close", lambda self, tokens, idx, options, env: "</table>\n</div>\n")
    tokens = md.parse(markdown)
    slug = Slugger()
    for i, tok in enumerate(tokens):          # heading ids: the anchors of a contents list
        if tok.type == "heading_open":
            tok.attrSet("id", slug(_plain(tokens[i + 1])))
    if title is None:
        title = next((tokens[i + 1].content for i, t in enumerate(tokens) if t.type == "heading_open"),
                     "roadbank report")
    body = md.renderer.render(tokens, md.options, {})
    return ("<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{html.escape(title)}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n"
            f"{body}</body>\n</html>\n")


def write_document(path, markdown: str, title: str | None = None) -> Path:
    """Write a report as a self-contained HTML page when ``path`` ends in ``.html``/``.htm``
    (relative figures resolved against ``path``'s folder and embedded), else as markdown."""
    path = Path(path)
    if path.suffix.lower() in (".html", ".htm"):
        text = md_to_html(markdown, title, base_dir=path.parent)
    else:
        text = markdown if markdown.endswith("\n") else markdown + "\n"
    path.write_text(text, encoding="utf-8")
    return path
