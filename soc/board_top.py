"""The DE1-SoC top level: pins, PLL and resets around the Platform Designer
system ``soc_system`` (HPS + :class:`soc.core.StereogestCore`).

::

    CLOCK_50 (AF14) --+--> altera_pll --> 100 MHz  soc_system clk (core clk, lw bridge)
                      |                   25 MHz   vga domain: VGA DAC, its clock pin
                      |                   24 MHz   xclk domain: both cameras' XCLK
                      +--> config domain (50 MHz): the cameras' I2C masters
    ov5642 #1 PCLK ------> cam_left domain  (left camera, GPIO_1)
    ov5642 #0 PCLK ------> cam_right domain (right camera, GPIO_0)
    KEY[0], PLL unlocked or the HPS's h2f_reset --> reset of every domain
                                                 (synchronised per domain here;
                                                 soc_system's reset input gets
                                                 it asynchronous, declared so:
                                                 Platform Designer synchronises)
    core left_power / right_power ------> each camera's PWDN and RESETB
    HPS peripheral pins <--> soc_system hps_io (dedicated HPS I/O, no FPGA logic)

The core sits inside ``soc_system``; its conduits come out as ``soc_system``
ports named by :func:`soc.platform_designer.exported_port_name`, and this top
wires each to its pins by the core port's name (the ``sources`` and ``sinks``
tables of :meth:`BoardTop.elaborate`). Board functions (KEY, SW, LEDR) are
listed in :mod:`boards.de1_soc`.
"""
from __future__ import annotations

from amaranth.hdl import Cat, ClockDomain, ClockSignal, Const, Elaboratable, Instance, Module, \
    ResetSignal, Signal
from amaranth.lib import io
from amaranth.lib.cdc import ResetSynchronizer

from boards.de1_soc import HPS_IO_PINS
from sim.model.validation import check_number

from .clocks import CONFIG_HZ, SYNC_HZ, VGA_HZ, XCLK_HZ
from .platform_designer import H2F_RESET_PORT, HPS_IO_PORTS, SYSTEM_NAME, conduit_map, \
    core_interfaces

__all__ = ["BoardTop", "PLL_REFERENCE_HZ", "PLL_OUTPUTS"]

#: The board oscillator feeding the PLL and the ``config`` domain.
PLL_REFERENCE_HZ = CONFIG_HZ
#: Clock domain of each PLL output, in output order (the constraints name the
#: PLL's clocks by this index).
PLL_OUTPUTS = ("sync", "vga", "xclk")
_SIDES = ("left", "right")
#: Core conduit ports the board drives (``sources`` of :meth:`BoardTop.elaborate`)
#: and reads (``sinks``), by the core port's name: checked when a top is made,
#: before anything is built for its pins.
_SOURCES = frozenset([
    *(f"{name}_{kind}" for name in ("cam_left", "cam_right", "config", "vga")
      for kind in ("clk", "rst")),
    *(f"{side}__{sig}" for side in _SIDES for sig in ("vsync", "href", "data")),
    *(f"{side}_i2c__{sig}_i" for side in _SIDES for sig in ("scl", "sda")),
    "uart_rx", "capture", "stage_select", "configure", "pause"])
_SINKS = frozenset([
    *(f"{side}_i2c__{sig}_oe" for side in _SIDES for sig in ("scl", "sda")),
    *(f"{side}_power__{sig}" for side in _SIDES for sig in ("pwdn", "reset_n")),
    "uart_tx", "leds",
    *(f"vga__{name}" for name in ("r", "g", "b", "hsync", "vsync", "blank_n"))])


def _mhz(hz: float) -> str:
    return f"{hz / 1e6:.6f} MHz"


class BoardTop(Elaboratable):
    """Top level of the FPGA design for :class:`boards.de1_soc.StereogestDE1SoCPlatform`.

    Parameters
    ----------
    core_ports : list of (name, direction, width)
        The core's ports (:func:`soc.core.core_ports`): the board wires each
        conduit port by name.
    sync_hz, vga_hz, xclk_hz : float
        PLL outputs: pipeline/bus clock (fed to ``soc_system``), VGA pixel
        clock and camera XCLK. Defaults from :mod:`soc.clocks` (100, 25 and
        24 MHz, all integer divisions of a 600 MHz VCO from the 50 MHz
        oscillator).

    Raises
    ------
    ValueError
        If a frequency is out of range, or the core has a conduit port this
        board does not know or with an unexpected direction.
    """

    def __init__(self, core_ports, *, sync_hz: float = SYNC_HZ, vga_hz: float = VGA_HZ,
                 xclk_hz: float = XCLK_HZ):
        self.core_ports = [(str(n), str(d), int(w)) for n, d, w in core_ports]
        core_interfaces(self.core_ports)        # validates the port list early
        self.sync_hz = check_number("sync_hz", sync_hz, 10e6, 200e6, unit="Hz")
        self.vga_hz = check_number("vga_hz", vga_hz, 10e6, 100e6, unit="Hz")
        # OV5642 XCLK range
        self.xclk_hz = check_number("xclk_hz", xclk_hz, 6e6, 27e6, unit="Hz")
        for core_port, (_, direction, _) in conduit_map(self.core_ports).items():
            if direction == "input":
                if core_port not in _SOURCES:
                    raise ValueError(f"core input {core_port!r} has no board connection")
            elif direction == "output":
                if core_port not in _SINKS:
                    raise ValueError(f"core output {core_port!r} has no board connection")
            else:
                raise ValueError(f"core port {core_port!r}: inout ports are not supported")

    def elaborate(self, platform):
        m = Module()

        # --- clocks ---------------------------------------------------------------------
        clk50_pin = platform.request("clk50", 0, dir="-")
        m.submodules.clk50_buf = clk50_buf = io.Buffer("i", clk50_pin)
        outclk, locked, fboutclk = Signal(len(PLL_OUTPUTS)), Signal(), Signal()
        frequency = {"sync": self.sync_hz, "vga": self.vga_hz, "xclk": self.xclk_hz}
        outputs = {}
        for n, domain in enumerate(PLL_OUTPUTS):
            outputs.update({f"p_output_clock_frequency{n}": _mhz(frequency[domain]),
                            f"p_phase_shift{n}": "0 ps", f"p_duty_cycle{n}": 50})
        m.submodules.pll = Instance(
            "altera_pll",
            p_fractional_vco_multiplier="false",
            p_reference_clock_frequency=_mhz(PLL_REFERENCE_HZ),
            p_operation_mode="direct",
            p_number_of_clocks=len(PLL_OUTPUTS),
            **outputs,
            p_pll_type="General", p_pll_subtype="General",
            i_refclk=clk50_buf.i, i_rst=Const(0), i_fbclk=Const(0),
            o_outclk=outclk, o_locked=locked, o_fboutclk=fboutclk)
        pll_clock = {domain: outclk[n] for n, domain in enumerate(PLL_OUTPUTS)}
        clk_sync = Signal()
        m.d.comb += clk_sync.eq(pll_clock["sync"])

        cams = {"right": platform.request("ov5642", 0, dir="-"),
                "left": platform.request("ov5642", 1, dir="-")}
        clocks = {"vga": pll_clock["vga"], "xclk": pll_clock["xclk"],
                  "config": clk50_buf.i}
        for side, cam in cams.items():
            m.submodules[f"{side}_pclk_buf"] = pclk = io.Buffer("i", cam.pclk)
            clocks[f"cam_{side}"] = pclk.i

        # --- reset: KEY[0] (active low on the board, inverted by the resource), the
        # PLL's lock and the HPS's reset of the FPGA side (h2f_reset, active low) ------
        key = [platform.request("button", i, dir="-") for i in range(3)]
        key_bufs = []
        for i, pin in enumerate(key):
            m.submodules[f"key{i}_buf"] = buf = io.Buffer("i", pin)
            key_bufs.append(buf.i)
        h2f_reset_n = Signal()
        board_reset = Signal()
        m.d.comb += board_reset.eq(key_bufs[0] | ~locked | ~h2f_reset_n)
        for name, clk in clocks.items():
            m.domains += ClockDomain(name)
            m.d.comb += ClockSignal(name).eq(clk)
            m.submodules[f"{name}_reset_sync"] = ResetSynchronizer(board_reset, domain=name)

        # --- board signals the core reads (_SOURCES) and drives (_SINKS) ----------------
        sources, sinks = {}, {}
        for name in ("cam_left", "cam_right", "config", "vga"):
            sources[f"{name}_clk"] = ClockSignal(name)
            sources[f"{name}_rst"] = ResetSignal(name)

        for side, cam in cams.items():
            cam_domain = f"cam_{side}"
            for sig in ("vsync", "href", "data"):
                # IOE registers in the camera's own clock: one cycle, same for all three
                m.submodules[f"{side}_{sig}_buf"] = buf = io.FFBuffer(
                    "i", getattr(cam, sig), i_domain=cam_domain)
                sources[f"{side}__{sig}"] = buf.i
            for sig in ("scl", "sda"):
                # open drain: drive 0 when the core pulls low, else release
                m.submodules[f"{side}_{sig}_buf"] = buf = io.Buffer("io", getattr(cam, sig))
                m.d.comb += buf.o.eq(0)
                sources[f"{side}_i2c__{sig}_i"] = buf.i
                sinks[f"{side}_i2c__{sig}_oe"] = buf.oe
            # XCLK forwarded through a DDR output register, in phase with the PLL output
            m.submodules[f"{side}_xclk_buf"] = xclk = io.DDRBuffer("o", cam.xclk,
                                                                   o_domain="xclk")
            m.d.comb += [xclk.o[0].eq(1), xclk.o[1].eq(0)]
            # PWDN and RESETB from the camera's configuration master (its power-up)
            for sig in ("reset_n", "pwdn"):
                m.submodules[f"{side}_{sig}_buf"] = buf = io.Buffer("o", getattr(cam, sig))
                sinks[f"{side}_power__{sig}"] = buf.o

        uart = platform.request("uart", 0, dir="-")
        m.submodules.uart_rx_buf = rx = io.Buffer("i", uart.rx)
        m.submodules.uart_tx_buf = tx = io.Buffer("o", uart.tx)
        m.d.comb += tx.o.eq(1)          # idle high if the core has no UART
        sources["uart_rx"] = rx.i
        sinks["uart_tx"] = tx.o

        switches = []
        for i in (0, 7, 8, 9):
            pin = platform.request("switch", i, dir="-")
            m.submodules[f"sw{i}_buf"] = buf = io.Buffer("i", pin)
            switches.append(buf.i)
        sources["capture"] = switches[0]
        sources["stage_select"] = Cat(*switches[1:])       # SW[9:7]
        sources["configure"] = key_bufs[1]
        sources["pause"] = key_bufs[2]

        leds = []
        for i in range(10):
            pin = platform.request("led", i, dir="-")
            m.submodules[f"led{i}_buf"] = buf = io.Buffer("o", pin)
            leds.append(buf.o)
        sinks["leds"] = Cat(*leds)

        vga = platform.request("vga", 0, dir="-")
        for core_name, pin_name in (("r", "r"), ("g", "g"), ("b", "b"), ("hsync", "hs"),
                                    ("vsync", "vs"), ("blank_n", "blank_n")):
            # IOE registers in the pixel clock: the DAC sees all signals aligned
            m.submodules[f"vga_{pin_name}_buf"] = buf = io.FFBuffer(
                "o", getattr(vga, pin_name), o_domain="vga")
            sinks[f"vga__{core_name}"] = buf.o
        m.submodules.vga_sync_n_buf = sync_n = io.Buffer("o", vga.sync_n)
        m.d.comb += sync_n.o.eq(0)      # no sync on green
        # the DAC latches on the rising edge of its clock: send the inverted pixel clock
        # so that edge falls in the middle of the data eye
        m.submodules.vga_clk_buf = vga_clk = io.DDRBuffer("o", vga.clk, o_domain="vga")
        m.d.comb += [vga_clk.o[0].eq(0), vga_clk.o[1].eq(1)]

        # --- the Platform Designer system -----------------------------------------------
        ddr = platform.request("hps_ddr3", 0, dir="-")
        ports = {
            "i_clk_clk": clk_sync,
            "i_reset_reset_n": ~board_reset,
            "o_memory_mem_a": ddr.a.io, "o_memory_mem_ba": ddr.ba.io,
            "o_memory_mem_ck": ddr.ck_p.io, "o_memory_mem_ck_n": ddr.ck_n.io,
            "o_memory_mem_cke": ddr.cke.io, "o_memory_mem_cs_n": ddr.cs_n.io,
            "o_memory_mem_ras_n": ddr.ras_n.io, "o_memory_mem_cas_n": ddr.cas_n.io,
            "o_memory_mem_we_n": ddr.we_n.io, "o_memory_mem_reset_n": ddr.reset_n.io,
            "io_memory_mem_dq": ddr.dq.io, "io_memory_mem_dqs": ddr.dqs_p.io,
            "io_memory_mem_dqs_n": ddr.dqs_n.io, "o_memory_mem_odt": ddr.odt.io,
            "o_memory_mem_dm": ddr.dm.io, "i_memory_oct_rzqin": ddr.rzq.io,
            f"o_{H2F_RESET_PORT[0]}": h2f_reset_n,
        }
        # the HPS peripheral pins go straight to the HPS's dedicated I/O
        hps_io = platform.request("hps_io", 0, dir="-")
        prefix = {"input": "i", "output": "o", "inout": "io"}
        for role, (sys_port, direction, _) in zip(HPS_IO_PINS, HPS_IO_PORTS):
            ports[f"{prefix[direction]}_{sys_port}"] = getattr(hps_io, role).io
        # (every conduit has its source or sink: checked in __init__)
        for core_port, (sys_port, direction, width) in conduit_map(self.core_ports).items():
            wire = Signal(width, name=f"core_{core_port}")
            if direction == "input":
                m.d.comb += wire.eq(sources[core_port])
                ports[f"i_{sys_port}"] = wire
            else:
                m.d.comb += sinks[core_port].eq(wire)
                ports[f"o_{sys_port}"] = wire
        m.submodules.soc = Instance(SYSTEM_NAME, **ports)
        return m
