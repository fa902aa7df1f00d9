"""Labelled grids of images: contact sheets and two-parameter atlases.

:func:`mosaic` lays out ``N`` equal tiles in rows, each with a caption strip below it — the
contact sheets of a genetic-algorithm generation (Skaggs figs. 4.1–4.6, seed 000 §4.1, tiles
labelled with index and fitness) or any list of runs. :func:`atlas_image` lays out a
``(NY, NX)`` grid of runs over two parameters with tick labels along the axes — the (F, k) map
of Gray-Scott pattern families (Richard et al. fig. 9, seed 001 §5.2.1; Pearson's map).

Text is drawn with Pillow in DejaVu Sans, the font bundled with matplotlib, so nothing depends
on the fonts installed on the machine. Font sizes follow the tile size and shrink (then wrap at
spaces onto two lines) until every caption fits its tile, so 64-pixel tiles stay readable.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from functools import lru_cache

import numpy as np
from matplotlib import font_manager
from PIL import Image, ImageDraw, ImageFont

from morphogen.errors import MorphogenError
from morphogen.render.colour import parse_colour

_MIN_FONT = 7
_MAX_LINES = 2


@lru_cache(maxsize=32)
def _font(size: int) -> ImageFont.FreeTypeFont:
    path = font_manager.findfont(font_manager.FontProperties(family="DejaVu Sans"))
    return ImageFont.truetype(path, size)


def _width(text: str, size: int) -> float:
    return _font(size).getlength(text)


def _line_height(size: int) -> int:
    ascent, descent = _font(size).getmetrics()
    return ascent + descent


def _wrap(text: str, size: int, width: float) -> list[str]:
    """Greedy word wrap of ``text`` at spaces (and at explicit newlines) to ``width`` pixels."""
    lines: list[str] = []
    for paragraph in text.split("\n"):
        line = ""
        for word in paragraph.split():
            trial = f"{line} {word}" if line else word
            if line and _width(trial, size) > width:
                lines.append(line)
                line = word
            else:
                line = trial
        lines.append(line)
    return lines


def _fit(texts: Sequence[str], width: float, preferred: int) -> tuple[int, list[list[str]]]:
    """One font size and wrapped lines for all ``texts`` so each line fits ``width`` pixels.

    Tries one line per text at the preferred size and slightly smaller, then up to two lines
    from the preferred size down to the minimum; beyond that the text is clipped.
    """
    one_line_floor = max(_MIN_FONT, math.floor(0.8 * preferred))
    tries = [(s, 1) for s in range(preferred, one_line_floor - 1, -1)]
    tries += [(s, _MAX_LINES) for s in range(preferred, _MIN_FONT - 1, -1)]
    for size, max_lines in tries:
        wrapped = [_wrap(t, size, width) if max_lines > 1 else [t] for t in texts]
        if all(
            len(lines) <= max_lines and all(_width(x, size) <= width for x in lines)
            for lines in wrapped
        ):
            return size, wrapped
    return _MIN_FONT, [_wrap(t, _MIN_FONT, width) for t in texts]


def _colour_bytes(colour: str) -> tuple[int, int, int]:
    r, g, b = np.rint(parse_colour(colour) * 255).astype(int).tolist()
    return r, g, b


def _text_block(
    lines: Sequence[str], size: int, width: int, height: int, bg: tuple, fg: tuple
) -> Image.Image:
    """A ``width`` x ``height`` image with ``lines`` centred horizontally, stacked from the top."""
    block = Image.new("RGB", (width, height), bg)
    draw = ImageDraw.Draw(block)
    lh = _line_height(size)
    for i, line in enumerate(lines):
        draw.text((width / 2, 1 + i * lh), line, font=_font(size), fill=fg, anchor="ma")
    return block


def _check_tiles(tiles: np.ndarray, ndim: int, shape_doc: str) -> np.ndarray:
    tiles = np.asarray(tiles)
    if tiles.dtype != np.uint8 or tiles.ndim != ndim or tiles.shape[-1] != 3:
        raise MorphogenError(
            f"tiles must be uint8 of shape {shape_doc}, got {tiles.dtype} {tiles.shape}"
        )
    if 0 in tiles.shape:
        raise MorphogenError(f"tiles are empty: shape {tiles.shape}")
    return tiles


def _title_strip(title: str, width: int, bg: tuple, fg: tuple) -> Image.Image:
    preferred = int(np.clip(round(width / 28), 10, 20))
    size, (lines,) = _fit([title], width - 4, preferred)
    return _text_block(lines, size, width, len(lines) * _line_height(size) + 4, bg, fg)


def caption_font_size(tile_width: int) -> int:
    """Preferred caption size in pixels for tiles ``tile_width`` wide (11 px for 64 px tiles)."""
    return int(np.clip(round(tile_width / 5.8), 8, 14))


def mosaic(
    tiles: np.ndarray,
    ncols: int,
    labels: Sequence[str] | None = None,
    pad: int = 2,
    title: str | None = None,
    *,
    background: str = "#ffffff",
    text_colour: str = "#000000",
) -> np.ndarray:
    """A grid of equal tiles, each optionally captioned below (a contact sheet).

    Args:
        tiles: ``(N, H, W, 3)`` uint8.
        ncols: tiles per row; ``nrows = ceil(N / ncols)``, missing cells are left blank.
        labels: ``N`` captions, e.g. ``"#3 f=0.812"`` or ``"F=0.030 k=0.060"``.
        pad: pixels between tiles and around the grid.
        title: optional heading above the grid.

    Returns:
        uint8 RGB of width ``ncols * W + (ncols + 1) * pad`` and height
        ``T + nrows * (H + L) + (nrows + 1) * pad``, where ``L`` is the caption strip height
        (0 without labels) and ``T`` the title strip height (0 without a title).
    """
    tiles = _check_tiles(tiles, 4, "(N, H, W, 3)")
    n, h, w, _ = tiles.shape
    if int(ncols) != ncols or ncols < 1:
        raise MorphogenError(f"ncols must be a positive integer, got {ncols}")
    if pad < 0:
        raise MorphogenError(f"pad must be >= 0, got {pad}")
    if labels is not None and len(labels) != n:
        raise MorphogenError(f"got {len(labels)} labels for {n} tiles; give one per tile")
    ncols = int(ncols)
    nrows = math.ceil(n / ncols)
    bg, fg = _colour_bytes(background), _colour_bytes(text_colour)
    width = ncols * w + (ncols + 1) * pad

    label_h, size, wrapped = 0, 0, []
    if labels is not None:
        size, wrapped = _fit([str(x) for x in labels], w - 2, caption_font_size(w))
        label_h = max(len(lines) for lines in wrapped) * _line_height(size) + 2
    head = _title_strip(title, width, bg, fg) if title else None
    top = head.height if head else 0

    canvas = Image.new("RGB", (width, top + nrows * (h + label_h) + (nrows + 1) * pad), bg)
    if head:
        canvas.paste(head, (0, 0))
    for i in range(n):
        row, col = divmod(i, ncols)
        x = pad + col * (w + pad)
        y = top + pad + row * (h + label_h + pad)
        canvas.paste(Image.fromarray(tiles[i]), (x, y))
        if labels is not None:
            canvas.paste(_text_block(wrapped[i], size, w, label_h, bg, fg), (x, y + h))
    return np.asarray(canvas)


def format_ticks(values: Sequence[float]) -> list[str]:
    """Tick labels with the fewest decimals (up to 6) that show every value exactly.

    ``[0.01, 0.014, 0.018]`` -> ``["0.010", "0.014", "0.018"]``; otherwise 4 significant digits.
    """
    v = np.asarray(values, dtype=np.float64)
    scale = max(float(np.max(np.abs(v))), 1e-300)
    for d in range(7):
        if np.allclose(np.round(v, d), v, rtol=0, atol=1e-9 * scale):
            return [f"{x:.{d}f}" for x in v]
    return [f"{x:.4g}" for x in v]


def _tick_step(label_extent: float, cell: int) -> int:
    """Show every ``k``-th tick so that labels ``label_extent`` pixels long do not overlap."""
    return max(1, math.ceil((label_extent + 4) / cell))


def frame_tiles(
    tiles: np.ndarray,
    labels: np.ndarray,
    colours: Mapping[str, str],
    *,
    width: int = 2,
    text: bool = True,
) -> np.ndarray:
    """Frame every tile in its label's colour and write the label in its top-left corner.

    Args:
        tiles: ``(..., H, W, 3)`` uint8; labels: the leading shape of ``tiles``, strings.
        colours: label -> ``"#rrggbb"``; the text is white on that colour.
        text: write the label; ``False`` draws the frame only (a page that names the tiles
            in a legend and on hover, where small tiles have no room for words).

    Returns:
        a copy of ``tiles`` with the frames and labels drawn.
    """
    tiles = np.asarray(tiles)
    labels = np.asarray(labels)
    if tiles.ndim < 3 or tiles.shape[-1] != 3 or tiles.shape[:-3] != labels.shape:
        raise MorphogenError(f"tiles {tiles.shape} need one label each, got {labels.shape}")
    h, w = tiles.shape[-3:-1]
    size = int(np.clip(round(w / 6), 8, 12))
    out = tiles.reshape(-1, h, w, 3).copy()
    for i, label in enumerate(labels.reshape(-1)):
        label = str(label)
        if label not in colours:
            raise MorphogenError(f"no colour for label {label!r}; known: {', '.join(colours)}")
        colour = _colour_bytes(colours[label])
        image = Image.fromarray(out[i])
        draw = ImageDraw.Draw(image)
        draw.rectangle([0, 0, w - 1, h - 1], outline=colour, width=width)
        if text:
            draw.rectangle([0, 0, math.ceil(_width(label, size)) + 3, _line_height(size)],
                           fill=colour)
            draw.text((2, 0), label, font=_font(size), fill=(255, 255, 255))
        out[i] = np.asarray(image)
    return out.reshape(tiles.shape)


def atlas_image(
    tiles: np.ndarray,
    x_name: str,
    x_values: Sequence[float],
    y_name: str,
    y_values: Sequence[float],
    *,
    title: str | None = None,
    pad: int = 1,
    y_up: bool = True,
    background: str = "#ffffff",
    text_colour: str = "#000000",
) -> np.ndarray:
    """A two-parameter atlas: runs on a grid of ``(y, x)`` parameter pairs, with labelled axes.

    ``tiles[i, j]`` is the run at ``(y_values[i], x_values[j])``. With ``y_up`` (default) the
    first ``y`` value is the bottom row, as on a plot (Pearson's map; Richard et al. fig. 9 plots
    feed against kill); otherwise it is the top row. Tick labels sit under the columns and to
    the left of the rows, thinned to every ``k``-th tick when tiles are too small for all.

    Args:
        tiles: ``(NY, NX, H, W, 3)`` uint8.
        x_name, y_name: axis names, e.g. ``"k"`` and ``"F"``.
        x_values: ``NX`` values; y_values: ``NY`` values.

    Returns:
        uint8 RGB image ``(height, width, 3)``.
    """
    tiles = _check_tiles(tiles, 5, "(NY, NX, H, W, 3)")
    ny, nx, h, w, _ = tiles.shape
    if len(x_values) != nx or len(y_values) != ny:
        raise MorphogenError(
            f"atlas of {ny}x{nx} tiles needs {nx} x values and {ny} y values, "
            f"got {len(x_values)} and {len(y_values)}"
        )
    if pad < 0:
        raise MorphogenError(f"pad must be >= 0, got {pad}")
    bg, fg = _colour_bytes(background), _colour_bytes(text_colour)
    size = int(np.clip(round(min(h, w) / 5), 9, 14))
    lh = _line_height(size)
    name_size = size + 2
    name_lh = _line_height(name_size)
    xt, yt = format_ticks(x_values), format_ticks(y_values)
    ytick_w = math.ceil(max(_width(t, size) for t in yt))
    tick_len = 3

    xtick_w = max(_width(t, size) for t in xt)
    left = name_lh + 4 + ytick_w + 3 + tick_len
    right = max(4, math.ceil(xtick_w / 2) - w // 2 + 2)
    grid_w = nx * (w + pad) + pad
    grid_h = ny * (h + pad) + pad
    head = _title_strip(title, left + grid_w + right, bg, fg) if title else None
    top = head.height if head else 2
    bottom = tick_len + 2 + lh + 2 + name_lh + 4
    canvas = Image.new("RGB", (left + grid_w + right, top + grid_h + bottom), bg)
    draw = ImageDraw.Draw(canvas)
    if head:
        canvas.paste(head, (0, 0))

    def row_y(i: int) -> int:
        r = ny - 1 - i if y_up else i
        return top + pad + r * (h + pad)

    for i in range(ny):
        for j in range(nx):
            canvas.paste(Image.fromarray(tiles[i, j]), (left + pad + j * (w + pad), row_y(i)))

    grid_bottom = top + grid_h
    xstep = _tick_step(xtick_w, w + pad)
    for j in range(0, nx, xstep):
        cx = left + pad + j * (w + pad) + w // 2
        draw.line([(cx, grid_bottom), (cx, grid_bottom + tick_len - 1)], fill=fg)
        draw.text((cx, grid_bottom + tick_len + 1), xt[j], font=_font(size), fill=fg, anchor="ma")
    ystep = _tick_step(lh, h + pad)
    for i in range(0, ny, ystep):
        cy = row_y(i) + h // 2
        draw.line([(left - tick_len, cy), (left - 1, cy)], fill=fg)
        draw.text((left - tick_len - 2, cy), yt[i], font=_font(size), fill=fg, anchor="rm")

    draw.text(
        (left + grid_w / 2, grid_bottom + tick_len + 2 + lh + 2),
        x_name, font=_font(name_size), fill=fg, anchor="ma",
    )
    label = Image.new("RGB", (math.ceil(_width(y_name, name_size)) + 2, name_lh), bg)
    ImageDraw.Draw(label).text((1, 0), y_name, font=_font(name_size), fill=fg)
    label = label.rotate(90, expand=True)
    canvas.paste(label, (2, top + grid_h // 2 - label.height // 2))
    return np.asarray(canvas)
