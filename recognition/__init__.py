"""Gesture recognition off the board: trajectory datasets, the synthetic corpus,
symbol features, HMM training and cross-validation (thesis §7.4, chapter 8).

The models it writes are read by the board application in :mod:`sw_hps`.
"""
