"""One HTML file that works from disk, offline: its data as JSON inside the page, its plotting
library and its code inline, no request outside the file.

The plots are Vega-Lite's, drawn in the browser by the bundle `vl-convert-python` ships (Vega,
Vega-Lite and vega-embed in one script of about 0.9 MB, from PyPI: no npm, no CDN); the bundle is
kept in the cache folder by its version, since producing it takes a second or two. The page's
own code and style (`web/page.js`, `web/page.css`) draw both pages: `pipeline derive`'s and the
paper's, from the data each writes.

Text from a run (a target's name, an expression, a description) only ever enters the page as JSON
in a `<script type="application/json">` element (its `<`, `>` and `&` escaped, so that no text
closes the element) or through `html.escape`; the page's code puts it in the document as text.
"""

from __future__ import annotations

import html
import json
import math
import os
from pathlib import Path

from . import paths

ASSETS = Path(__file__).parent / "web"


def vega_bundle() -> str:
    """Vega, Vega-Lite and vega-embed as one script (it sets window.vega, window.vegaLite and
    window.vegaEmbed), kept in `paths.WEB_CACHE` by the library's version."""
    import vl_convert

    version = f"vega-{vl_convert.get_vega_version()}-embed-{vl_convert.get_vega_embed_version()}"
    kept = paths.WEB_CACHE / f"{version}.js"
    if kept.exists():
        return kept.read_text()
    bundle = vl_convert.javascript_bundle()
    if "</script" in bundle.lower() or "<!--" in bundle:
        raise RuntimeError("the Vega bundle holds text that would end its script element")
    kept.parent.mkdir(parents=True, exist_ok=True)
    partial = kept.with_suffix(f".{os.getpid()}.tmp")
    partial.write_text(bundle)
    os.replace(partial, kept)
    return bundle


def assets_digest() -> str:
    """A digest of what every page holds besides its data: the page's code and style and the Vega
    bundle's version (an output folder keyed on it is written again when they change)."""
    import hashlib

    import vl_convert

    h = hashlib.sha256()
    for name in ("page.js", "page.css"):
        h.update((ASSETS / name).read_bytes())
    h.update(f"{vl_convert.get_vega_version()} {vl_convert.get_vega_embed_version()}".encode())
    return h.hexdigest()


def _finite(value):
    """`value` with every float that JSON cannot hold (inf, nan) as a string ("inf", "-inf", "nan")."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def json_island(data) -> str:
    """`data` as JSON that can stand inside a script element: no `<`, `>` or `&` in it (written as
    \\u escapes, which JSON reads back as the same characters)."""
    text = json.dumps(_finite(data), separators=(",", ":"), allow_nan=False)
    return text.replace("&", "\\u0026").replace("<", "\\u003c").replace(">", "\\u003e")


def page(title: str, data) -> str:
    """The whole page: `title` (escaped), `data` as the JSON island `page.js` reads, the style, the
    Vega bundle and the page's code."""
    style = (ASSETS / "page.css").read_text()
    code = (ASSETS / "page.js").read_text()
    for name, text in (("page.js", code), ("page.css", style)):
        if "</script" in text.lower() or "</style" in text.lower():
            raise RuntimeError(f"{name} holds text that would end its element")
    return "\n".join([
        "<!doctype html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        # Nothing outside the file: no script, style, image or connection from elsewhere.
        '<meta http-equiv="Content-Security-Policy" content="default-src \'none\'; script-src \'unsafe-inline\' \'unsafe-eval\'; '
        'style-src \'unsafe-inline\'; img-src data: blob:; font-src data:">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{style}</style>",
        "</head>",
        "<body>",
        '<main id="page"><p id="loading">Drawing the page…</p></main>',
        f'<script type="application/json" id="data">{json_island(data)}</script>',
        f"<script>{vega_bundle()}</script>",
        f"<script>{code}</script>",
        "</body>",
        "</html>",
        "",
    ])
