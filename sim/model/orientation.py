"""Orientation symbols of trajectory steps (thesis §7.4, Fig. 82).

The implementation lives in :mod:`sw_hps.orientation` because it runs on the ARM;
the golden model re-exports it so that there is a single definition.
"""
from sw_hps.orientation import NO_SYMBOL, NUM_SYMBOLS, orientation_symbols

__all__ = ["NUM_SYMBOLS", "NO_SYMBOL", "orientation_symbols"]
