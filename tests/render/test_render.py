"""Rendering: exact colours, degenerate fields, mosaics, animations, atomic files, galleries."""

from __future__ import annotations

import os
import re

import imageio.v2 as iio2
import imageio.v3 as iio
import matplotlib
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.render import (
    NAN_COLOUR,
    atlas_image,
    colourise,
    format_ticks,
    mid_slice,
    parse_cmap,
    parse_colour,
    slice_montage,
    state_image,
    step_map,
    threshold_map,
    upscale,
    write_animation,
    write_gallery,
    write_gif,
    write_mp4,
    write_png,
)
from morphogen.render.mosaic import mosaic

MAGENTA = (255, 0, 255)


def _ffmpeg_missing() -> str | None:
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError) as exc:
        return f"no ffmpeg executable (imageio-ffmpeg missing or without a binary): {exc}"
    return None


# ---- colour -------------------------------------------------------------------------------


def test_even_ramp_gives_exact_colours_at_stops_and_midpoints():
    field = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    rgb = colourise(field, "#000000,#ff8800,#ffffff")
    assert rgb.dtype == np.uint8 and rgb.shape == (5, 3)
    np.testing.assert_array_equal(rgb[0], (0, 0, 0))
    np.testing.assert_array_equal(rgb[2], (255, 136, 0))
    np.testing.assert_array_equal(rgb[4], (255, 255, 255))
    # halfway between stops: linear interpolation in RGB (to within rounding)
    assert np.abs(rgb[1].astype(int) - (127.5, 68, 0)).max() <= 0.5
    assert np.abs(rgb[3].astype(int) - (255, 195.5, 127.5)).max() <= 0.5


def test_positioned_ramp_hits_stops_with_vmin_vmax():
    # scale [10, 20]; stops at 0, 0.3, 1 -> values 10, 13, 20; short hex codes allowed
    field = np.array([[10.0, 13.0], [20.0, 25.0]])
    rgb = colourise(field, "0:#000,0.3:#f80,1:#fff", vmin=10, vmax=20)
    np.testing.assert_array_equal(rgb[0, 0], (0, 0, 0))
    np.testing.assert_array_equal(rgb[0, 1], (255, 136, 0))
    np.testing.assert_array_equal(rgb[1, 0], (255, 255, 255))
    np.testing.assert_array_equal(rgb[1, 1], (255, 255, 255))  # clipped above vmax


def test_matplotlib_colormap_ends_match_matplotlib():
    rgb = colourise(np.array([2.0, 7.0]), "magma")
    lut = matplotlib.colormaps["magma"]
    np.testing.assert_array_equal(rgb[0], np.rint(np.array(lut(0.0)[:3]) * 255))
    np.testing.assert_array_equal(rgb[1], np.rint(np.array(lut(1.0)[:3]) * 255))


def test_parse_cmap_returns_colormaps():
    viridis = parse_cmap("viridis")
    assert viridis.name == "viridis"
    np.testing.assert_array_equal(viridis(0.3), matplotlib.colormaps["viridis"](0.3))
    ramp = parse_cmap("#000000,#ffffff")
    assert isinstance(ramp, matplotlib.colors.Colormap)
    np.testing.assert_allclose(ramp(1.0)[:3], (1, 1, 1))


@pytest.mark.parametrize("bad", ["not-a-colormap", "virdis"])
def test_unknown_colormap_raises_with_hint(bad):
    with pytest.raises(MorphogenError, match="colormap_names"):
        colourise(np.zeros((2, 2)), bad)


@pytest.mark.parametrize(
    "ramp", ["#000", "#000,#zzzzzz", "0:#000,#fff", "0.1:#000,1:#fff", "0:#000,a:#fff"]
)
def test_malformed_ramps_raise(ramp):
    with pytest.raises(MorphogenError):
        colourise(np.zeros((2, 2)), ramp)


def test_constant_field_is_low_end_without_nan_or_warnings():
    with np.errstate(all="raise"):
        rgb = colourise(np.full((4, 4), 3.7), "#102030,#ffffff")
    assert (rgb == (16, 32, 48)).all()


def test_nan_and_inf_are_flagged_and_ignored_by_the_scale():
    field = np.array([[0.0, np.nan], [np.inf, 2.0]])
    rgb = colourise(field, "#000000,#ffffff")
    np.testing.assert_array_equal(rgb[0, 1], MAGENTA)
    np.testing.assert_array_equal(rgb[1, 0], MAGENTA)
    np.testing.assert_array_equal(rgb[0, 0], (0, 0, 0))  # scale from finite cells: [0, 2]
    np.testing.assert_array_equal(rgb[1, 1], (255, 255, 255))
    assert tuple(parse_colour(NAN_COLOUR)) == (1.0, 0.0, 1.0)


def test_all_nan_field_is_all_flag_colour():
    rgb = colourise(np.full((3, 3), np.nan), nan_colour="#00ff00")
    assert (rgb == (0, 255, 0)).all()


def test_reversed_limits_raise_but_one_sided_limit_beyond_data_is_accepted():
    with pytest.raises(MorphogenError, match="reversed"):
        colourise(np.zeros(3), vmin=2, vmax=1)
    rgb = colourise(np.array([0.0, 1.0]), "#000,#fff", vmin=5)
    assert (rgb == 0).all()


def test_threshold_map_gives_exactly_two_colours_split_at_level():
    field = np.linspace(0.0, 1.0, 101).reshape(1, 101)
    rgb = threshold_map(field, 0.42, low="#ffffff", high="#6a0dad")
    colours = {tuple(c) for c in rgb.reshape(-1, 3)}
    assert colours == {(255, 255, 255), (106, 13, 173)}
    high = (rgb == (106, 13, 173)).all(axis=-1)[0]
    np.testing.assert_array_equal(high, field[0] >= 0.42)


def test_step_map_levels_and_colours():
    field = np.array([-1.0, 0.0, 0.5, 1.0, 2.0, np.nan])
    rgb = step_map(field, [0.0, 1.0], ["#ff0000", "#00ff00", "#0000ff"])
    expected = [(255, 0, 0), (0, 255, 0), (0, 255, 0), (0, 0, 255), (0, 0, 255), MAGENTA]
    np.testing.assert_array_equal(rgb, expected)
    with pytest.raises(MorphogenError, match="one more colour"):
        step_map(field, [0.0, 1.0], ["#fff", "#000"])
    with pytest.raises(MorphogenError, match="increasing"):
        step_map(field, [1.0, 0.0], ["#fff", "#000", "#f00"])


# ---- images -------------------------------------------------------------------------------


def test_write_png_round_trip_and_atomic(tmp_path, monkeypatch):
    rgb = colourise(np.arange(12.0).reshape(3, 4), "viridis")
    path = write_png(tmp_path / "sub" / "a.png", rgb)
    np.testing.assert_array_equal(iio.imread(path), rgb)
    assert sorted(p.name for p in path.parent.iterdir()) == ["a.png"]

    # the target appears only by renaming a complete PNG written next to it
    renamed = []
    original = os.replace

    def spy_replace(src, dst):
        renamed.append((os.path.dirname(src), iio.imread(src).shape))
        return original(src, dst)

    monkeypatch.setattr(os, "replace", spy_replace)
    write_png(path, np.zeros((5, 6, 3), np.uint8))
    assert renamed == [(str(path.parent), (5, 6, 3))]

    # a write interrupted before the rename keeps the old file and leaves no temporary file
    def interrupted(fd):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_png(path, np.full((7, 7, 3), 9, np.uint8))
    assert iio.imread(path).shape == (5, 6, 3)
    assert sorted(p.name for p in path.parent.iterdir()) == ["a.png"]


def test_write_png_rejects_float_images(tmp_path):
    with pytest.raises(MorphogenError, match="uint8"):
        write_png(tmp_path / "x.png", np.zeros((4, 4, 3)))
    assert not (tmp_path / "x.png").exists()


def test_upscale_is_nearest_neighbour():
    rgb = np.arange(12, dtype=np.uint8).reshape(2, 2, 3)
    big = upscale(rgb, 3)
    assert big.shape == (6, 6, 3)
    np.testing.assert_array_equal(big[::3, ::3], rgb)
    np.testing.assert_array_equal(big[2, 2], rgb[0, 0])


def test_3d_state_mid_slice_and_montage_share_the_volume_scale():
    d, h, w = 7, 5, 6
    vol = np.broadcast_to(np.arange(d, dtype=float)[:, None, None], (d, h, w))
    np.testing.assert_array_equal(mid_slice(vol), vol[3])
    img = state_image(vol, "#000000,#ffffff")
    assert img.shape == (h, w, 3)
    assert (img == round(3 / 6 * 255)).all()  # z=3 of [0, 6], not its own constant scale

    montage = slice_montage(vol, n=4, ncols=2, labels=False, pad=2)
    assert montage.shape == (2 * h + 3 * 2, 2 * w + 3 * 2, 3)
    labelled = slice_montage(vol, n=4, ncols=2, pad=2)
    assert labelled.shape[1] == montage.shape[1] and labelled.shape[0] > montage.shape[0]


def test_state_image_rejects_1d():
    with pytest.raises(MorphogenError, match="2D"):
        state_image(np.zeros(5))


# ---- mosaics ------------------------------------------------------------------------------


def _tiles(n: int, h: int = 64, w: int = 64) -> np.ndarray:
    rng = np.random.default_rng(0)
    return colourise(rng.random((n, h, w)), "magma")


def test_mosaic_shape_and_tile_placement():
    tiles = _tiles(7, 20, 30)
    out = mosaic(tiles, ncols=3, pad=2)
    assert out.shape == (3 * 20 + 4 * 2, 3 * 30 + 4 * 2, 3)
    np.testing.assert_array_equal(out[2:22, 2:32], tiles[0])
    np.testing.assert_array_equal(out[24:44, 34:64], tiles[4])  # row 1, column 1
    assert (out[46:66, 34:64] == 255).all()  # empty cell stays background


def test_mosaic_labels_change_pixels_only_in_caption_strips():
    tiles = _tiles(6)
    plain = mosaic(tiles, ncols=3, pad=2)
    a = mosaic(tiles, ncols=3, labels=[f"#{i} f=0.812" for i in range(6)], pad=2)
    b = mosaic(tiles, ncols=3, labels=[f"#{i} f=0.113" for i in range(6)], pad=2)
    assert a.shape == b.shape and a.shape[1] == plain.shape[1]
    strip = (a.shape[0] - plain.shape[0]) // 2
    assert 8 <= strip <= 40  # one or two readable lines per caption
    assert not np.array_equal(a, b)
    np.testing.assert_array_equal(a[2:66, 2:66], tiles[0])
    caption = a[66 : 66 + strip, 2:66]
    assert (caption < 128).any()  # dark text drawn on the white strip
    with pytest.raises(MorphogenError, match="labels"):
        mosaic(tiles, 3, labels=["only one"])


def test_mosaic_title_adds_a_strip_on_top():
    tiles = _tiles(2, 16, 16)
    out = mosaic(tiles, 2, title="generation 1")
    plain = mosaic(tiles, 2)
    top = out.shape[0] - plain.shape[0]
    assert top > 0
    np.testing.assert_array_equal(out[top:], plain)


def test_format_ticks_uses_fewest_exact_decimals():
    assert format_ticks(np.linspace(0.01, 0.07, 4)) == ["0.01", "0.03", "0.05", "0.07"]
    assert format_ticks(np.linspace(0.01, 0.07, 16))[:3] == ["0.010", "0.014", "0.018"]
    assert format_ticks([0.062, 0.06093]) == ["0.06200", "0.06093"]
    assert format_ticks([1, 2, 3]) == ["1", "2", "3"]


def test_atlas_places_first_y_at_the_bottom_and_changes_with_labels():
    ny, nx, h = 3, 4, 24
    tiles = np.zeros((ny, nx, h, h, 3), np.uint8)
    for i in range(ny):
        tiles[i, :, :, :, 0] = 80 * (i + 1)  # red level encodes the row's y index
    xs, ys = np.linspace(0.04, 0.07, nx), np.linspace(0.01, 0.07, ny)
    img = atlas_image(tiles, "k", xs, "F", ys, pad=1)
    reds = img[..., 0][(img[..., 1] == 0) & (img[..., 2] == 0)]
    assert set(np.unique(reds)) >= {80, 160, 240}
    rows = [np.nonzero((img[..., 0] == 80 * (i + 1)) & (img[..., 1] == 0))[0] for i in range(ny)]
    assert rows[0].min() > rows[1].max() > rows[2].max()  # y increases upwards
    down = atlas_image(tiles, "k", xs, "F", ys, pad=1, y_up=False)
    rows = [np.nonzero((down[..., 0] == 80 * (i + 1)) & (down[..., 1] == 0))[0] for i in range(ny)]
    assert rows[0].max() < rows[1].min()
    other = atlas_image(tiles, "kill", xs, "feed", ys + 0.001, pad=1)
    assert not np.array_equal(img, other[: img.shape[0], : img.shape[1]])
    with pytest.raises(MorphogenError, match="x values"):
        atlas_image(tiles, "k", xs[:2], "F", ys)


# ---- animations ---------------------------------------------------------------------------


def _frames(f: int, h: int, w: int) -> np.ndarray:
    t = np.linspace(0, 1, f)[:, None, None] + np.linspace(0, 1, w)[None, None, :]
    return colourise(np.broadcast_to(t, (f, h, w)) % 1.0, "gray")


def test_gif_round_trip(tmp_path):
    frames = _frames(5, 12, 16)
    path = write_gif(tmp_path / "a.gif", frames, fps=20)
    back = iio.imread(path, index=None)
    assert back.shape[0] == 5 and back.shape[1:3] == (12, 16)
    assert np.abs(back[..., :3].astype(int) - frames).max() <= 8  # grey ramp survives quantising
    meta = iio.immeta(path, index=0)
    assert meta["duration"] == 50
    assert [p.name for p in tmp_path.iterdir()] == ["a.gif"]


def test_mp4_written_readable_and_padded_to_even_size(tmp_path):
    reason = _ffmpeg_missing()
    if reason:
        pytest.skip(reason)
    frames = _frames(6, 15, 21)
    path = write_animation(tmp_path / "a.mp4", frames, fps=12)
    reader = iio2.get_reader(path, format="FFMPEG")
    back = np.stack([frame for frame in reader])
    fps = reader.get_meta_data()["fps"]
    reader.close()
    assert back.shape == (6, 16, 22, 3)
    assert fps == pytest.approx(12)
    assert np.abs(back[:, :15, :21].astype(int) - frames).mean() < 6
    assert [p.name for p in tmp_path.iterdir()] == ["a.mp4"]


def test_animation_rejects_bad_input(tmp_path):
    frames = _frames(2, 4, 4)
    with pytest.raises(MorphogenError, match=r"\.gif or \.mp4"):
        write_animation(tmp_path / "a.avi", frames)
    with pytest.raises(MorphogenError, match="uint8"):
        write_gif(tmp_path / "a.gif", frames.astype(float))
    with pytest.raises(MorphogenError, match="positive"):
        write_mp4(tmp_path / "a.mp4", frames, fps=0)
    assert list(tmp_path.iterdir()) == []


# ---- gallery ------------------------------------------------------------------------------


def test_gallery_is_self_contained_and_escaped(tmp_path):
    write_png(tmp_path / "img" / "a b.png", np.zeros((2, 2, 3), np.uint8))
    write_gif(tmp_path / "g.gif", _frames(2, 4, 4))
    page = write_gallery(
        tmp_path, "Gray-Scott <demo>", [("img/a b.png", "F=0.037 & k=0.06"), ("g.gif", "growth")],
        wide=["g.gif"],
    )
    text = page.read_text()
    assert "Gray-Scott &lt;demo&gt;" in text and "F=0.037 &amp; k=0.06" in text
    assert 'src="img/a%20b.png"' in text and 'class="wide"' in text
    assert not re.search(r"https?://|<script|<link|@import|@font-face", text)
    assert "grid-template-columns" in text


@pytest.mark.parametrize("item", ["missing.png", "../x.png", "/etc/passwd"])
def test_gallery_rejects_missing_or_escaping_items(tmp_path, item):
    with pytest.raises(MorphogenError):
        write_gallery(tmp_path, "t", [(item, "c")])
    assert not (tmp_path / "index.html").exists()
