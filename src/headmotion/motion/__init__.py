"""Head-motion modelling below the systems: segmentation at extrema and template warping
(thesis §5.1–5.3), and the template discovery analysis (§5.3, :mod:`.discovery`, imported on use)."""

from .segmentation import Segments, segment, segment_axis, smooth
from .templates import Encoding, decode, decode_axis, encode, encode_axis, encoding_errors, render

__all__ = ["Segments", "segment", "segment_axis", "smooth", "Encoding", "encode", "encode_axis",
           "decode", "decode_axis", "render", "encoding_errors"]
