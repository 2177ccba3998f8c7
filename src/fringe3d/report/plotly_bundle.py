"""plotly.js inside a report page, gzip-compressed: the page stays self-contained at a third of the size.

plotly.js (~4.8 MB minified) is most of a report page. The page carries it gzip-compressed and
base64-encoded (~2 MB) and unpacks it on load with the browser's ``DecompressionStream``
(Chrome/Edge 80+, Firefox 113+, Safari 16.4+); the page's drawing code runs once plotly is in
place (:func:`draw_script` defines it, :func:`loader_script` calls it). A browser without
``DecompressionStream`` shows a line saying so instead of the plots; tables and images still show.
The compression is deterministic (``mtime=0``), so a seeded run gives the same page twice.
"""
from __future__ import annotations

import base64
import functools
import gzip

__all__ = ["loader_script", "draw_script"]

_NO_STREAMS = ("this browser cannot unpack the report's embedded plotly.js (it needs DecompressionStream: "
               "Chrome/Edge 80+, Firefox 113+, Safari 16.4+); the plots are not shown")


@functools.lru_cache(maxsize=2)
def _packed(plotly_js: str) -> str:
    return base64.b64encode(gzip.compress(plotly_js.encode("utf-8"), compresslevel=9, mtime=0)).decode("ascii")


def loader_script(plotly_js: str) -> str:
    """``<script>`` that unpacks the gzip'd, base64 ``plotly_js`` and then calls ``fringe3dDraw()``
    (after the document is parsed)."""
    return ("<script>(function(){"
            "function go(){if(window.fringe3dDraw)window.fringe3dDraw();}"
            "function later(f){if(document.readyState==='loading')document.addEventListener('DOMContentLoaded',f);"
            "else f();}"
            "if(typeof DecompressionStream==='undefined'){later(function(){const p=document.createElement('p');"
            f"p.className='muted';p.textContent={_NO_STREAMS!r};document.body.prepend(p);}});return;}}"
            f"const b=atob('{_packed(plotly_js)}'),u=new Uint8Array(b.length);"
            "for(let i=0;i<b.length;i++)u[i]=b.charCodeAt(i);"
            "new Response(new Blob([u]).stream().pipeThrough(new DecompressionStream('gzip'))).text().then(function(t){"
            "const s=document.createElement('script');s.text=t;document.head.appendChild(s);later(go);});"
            "})();</script>")


def draw_script(js: str) -> str:
    """``<script>`` defining ``fringe3dDraw()``, the page's drawing code ``js`` (run once plotly is loaded)."""
    return "<script>window.fringe3dDraw=function(){" + js + "};</script>"
