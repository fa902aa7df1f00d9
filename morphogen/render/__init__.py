"""Rendering: colour maps, PNG images, GIF/MP4 animations, labelled mosaics and HTML galleries.

Everything here runs outside ``jit``: NumPy arrays in, ``uint8`` RGB arrays or files out, every
file written atomically.
"""

from morphogen.render.animation import ANIMATION_FORMATS as ANIMATION_FORMATS
from morphogen.render.animation import pad_even as pad_even
from morphogen.render.animation import write_animation as write_animation
from morphogen.render.animation import write_gif as write_gif
from morphogen.render.animation import write_mp4 as write_mp4
from morphogen.render.colour import NAN_COLOUR as NAN_COLOUR
from morphogen.render.colour import Ramp as Ramp
from morphogen.render.colour import colormap_names as colormap_names
from morphogen.render.colour import colour_limits as colour_limits
from morphogen.render.colour import colourise as colourise
from morphogen.render.colour import normalise as normalise
from morphogen.render.colour import parse_cmap as parse_cmap
from morphogen.render.colour import parse_colour as parse_colour
from morphogen.render.colour import parse_ramp as parse_ramp
from morphogen.render.colour import step_map as step_map
from morphogen.render.colour import threshold_map as threshold_map
from morphogen.render.gallery import write_gallery as write_gallery
from morphogen.render.images import check_image as check_image
from morphogen.render.images import mid_slice as mid_slice
from morphogen.render.images import slice_indices as slice_indices
from morphogen.render.images import slice_montage as slice_montage
from morphogen.render.images import state_image as state_image
from morphogen.render.images import to_uint8 as to_uint8
from morphogen.render.images import upscale as upscale
from morphogen.render.images import write_png as write_png
from morphogen.render.mosaic import atlas_image as atlas_image
from morphogen.render.mosaic import caption_font_size as caption_font_size
from morphogen.render.mosaic import format_ticks as format_ticks
from morphogen.render.mosaic import mosaic as mosaic
