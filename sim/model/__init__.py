"""Numpy golden model of the stereogest pipeline: the bit-exact specification of
every hardware block (thesis Guerrero-Balaguera 2016)."""
from .census import census_bits, census_offsets, sparse_census
from .centroid import Centroid, MomentWidths, centroid, moment_widths
from .gesture_spotting import gesture_spotting
from .matching import (disparity_maps, hamming_volume, lr_consistency, shd_volume,
                       window_sum, winner_take_all)
from .median import median3x3
from .moving_average import moving_average
from .morphology import closing, dilate, erode, opening, structuring_element
from .orientation import NO_SYMBOL, NUM_SYMBOLS, orientation_symbols
from .segmentation import disparity_band, hand_mask, skin_mask
from .stereo import StereoResult, stereo_match
from .ycbcr import ycbcr422_to_444, ycbcr444_to_422

__all__ = [
    "ycbcr422_to_444", "ycbcr444_to_422",
    "median3x3",
    "census_offsets", "census_bits", "sparse_census",
    "hamming_volume", "window_sum", "shd_volume", "winner_take_all", "lr_consistency",
    "disparity_maps", "StereoResult", "stereo_match",
    "skin_mask", "disparity_band", "hand_mask",
    "structuring_element", "erode", "dilate", "opening", "closing",
    "Centroid", "MomentWidths", "centroid", "moment_widths",
    "moving_average", "gesture_spotting",
    "NUM_SYMBOLS", "NO_SYMBOL", "orientation_symbols",
]
