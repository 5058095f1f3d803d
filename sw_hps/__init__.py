"""sw_hps package."""
