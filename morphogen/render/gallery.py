"""A self-contained HTML page showing a directory's images in a responsive grid.

The page has inline CSS only — no scripts, CDNs or web fonts — so it opens offline from the
file system. Images are drawn with ``image-rendering: pixelated`` so small simulation grids
stay sharp when the browser enlarges them (``smooth=True`` turns that off for rendered scenes,
such as meshes, that the browser shrinks); ``.mp4`` items become looping videos.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path, PurePosixPath
from urllib.parse import quote

from morphogen.errors import MorphogenError
from morphogen.util.io import ensure_writable_dir, write_atomic

_STYLE = """
body { margin: 1.5rem; font-family: system-ui, -apple-system, "Segoe UI", sans-serif;
       color: #222; background: #fafafa; }
h1 { font-size: 1.4rem; margin: 0 0 0.5rem; }
p.intro { max-width: 60rem; }
.grid { display: grid; gap: 1rem;
        grid-template-columns: repeat(auto-fill, minmax(min(100%, 260px), 1fr)); }
figure { margin: 0; background: #fff; border: 1px solid #ddd; border-radius: 4px;
         padding: 0.5rem; }
figure.wide { grid-column: 1 / -1; }
figure img, figure video { width: 100%; height: auto; display: block;
                           image-rendering: pixelated; }
figure.wide img { width: auto; max-width: 100%; margin: 0 auto; }
main.smooth figure img { image-rendering: auto; }
figcaption { font-size: 0.85rem; margin-top: 0.4rem; overflow-wrap: anywhere; }
"""


def _check_item(directory: Path, rel: str) -> str:
    p = PurePosixPath(str(rel).replace("\\", "/"))
    if p.is_absolute() or ".." in p.parts or not p.parts:
        raise MorphogenError(
            f"gallery item {rel!r} must be a path relative to {directory} without '..'"
        )
    if not (directory / p).is_file():
        raise MorphogenError(f"gallery item {rel!r} does not exist in {directory}; write it first")
    return quote(str(p))


def _figure(src: str, caption: str, wide: bool) -> str:
    cap = html.escape(caption)
    if src.lower().endswith(".mp4"):
        media = f'<video src="{src}" autoplay loop muted playsinline controls></video>'
    else:
        media = f'<a href="{src}"><img src="{src}" alt="{cap}" loading="lazy"></a>'
    cls = ' class="wide"' if wide else ""
    return f"<figure{cls}>{media}<figcaption>{cap}</figcaption></figure>"


def write_gallery(
    directory: str | Path,
    title: str,
    items: Sequence[tuple[str, str]],
    *,
    intro: str | None = None,
    wide: Sequence[str] = (),
    filename: str = "index.html",
    smooth: bool = False,
) -> Path:
    """Write ``directory/index.html`` (atomically) showing ``items`` in a responsive grid.

    Args:
        directory: where the page goes; the items' paths are relative to it.
        title: page heading.
        items: ``(relative image path, caption)`` pairs, in display order; each file must exist.
            ``.png``/``.gif``/... are shown as images, ``.mp4`` as a looping video.
        intro: optional paragraph under the heading.
        wide: relative paths to show across the full width (e.g. an atlas or contact sheet).
        filename: name of the page.
        smooth: draw images with the browser's smooth scaling instead of pixelated (for
            rendered scenes larger than their figure, rather than small grids).

    Returns:
        The path of the page.
    """
    directory = ensure_writable_dir(directory)
    wide_set = {str(PurePosixPath(w)) for w in wide}
    figures = [
        _figure(_check_item(directory, rel), caption, str(PurePosixPath(rel)) in wide_set)
        for rel, caption in items
    ]
    head = html.escape(title)
    intro_html = f'<p class="intro">{html.escape(intro)}</p>\n' if intro else ""
    grid = "grid smooth" if smooth else "grid"
    page = (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{head}</title>\n<style>{_STYLE}</style>\n</head>\n<body>\n"
        f"<h1>{head}</h1>\n{intro_html}<main class=\"{grid}\">\n"
        + "\n".join(figures)
        + "\n</main>\n</body>\n</html>\n"
    )
    return write_atomic(directory / filename, lambda fh: fh.write(page.encode("utf-8")))
