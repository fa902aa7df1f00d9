"""Rendering: colour maps, PNG images, GIF/MP4 animations, labelled mosaics and HTML galleries.

Everything here runs outside ``jit``: NumPy arrays in, ``uint8`` RGB arrays or files out, every
file written atomically.
"""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "ANIMATION_FORMATS": "morphogen.render.animation",
    "pad_even": "morphogen.render.animation",
    "write_animation": "morphogen.render.animation",
    "write_gif": "morphogen.render.animation",
    "write_mp4": "morphogen.render.animation",
    "NAN_COLOUR": "morphogen.render.colour",
    "Ramp": "morphogen.render.colour",
    "colormap_names": "morphogen.render.colour",
    "colour_limits": "morphogen.render.colour",
    "colourise": "morphogen.render.colour",
    "normalise": "morphogen.render.colour",
    "parse_cmap": "morphogen.render.colour",
    "parse_colour": "morphogen.render.colour",
    "parse_ramp": "morphogen.render.colour",
    "step_map": "morphogen.render.colour",
    "threshold_map": "morphogen.render.colour",
    "write_gallery": "morphogen.render.gallery",
    "check_image": "morphogen.render.images",
    "mid_slice": "morphogen.render.images",
    "slice_indices": "morphogen.render.images",
    "slice_montage": "morphogen.render.images",
    "state_image": "morphogen.render.images",
    "to_uint8": "morphogen.render.images",
    "upscale": "morphogen.render.images",
    "write_png": "morphogen.render.images",
    "atlas_image": "morphogen.render.mosaic",
    "caption_font_size": "morphogen.render.mosaic",
    "format_ticks": "morphogen.render.mosaic",
})
