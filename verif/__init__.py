"""Simulation of the hardware: Verilator builds and runners (stereo matcher,
gesture pipeline, whole system), the Amaranth-simulator stream driver, the
cocotb runner and the C++ harnesses (``verif/cpp``). See verif/README.md."""
