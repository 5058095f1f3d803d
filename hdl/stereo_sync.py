"""Stereo frame synchroniser (thesis §5.3, Table 10).

The two cameras run on their own pixel clocks and start their frames at different
times. Each capture writes its words into a :class:`~hdl.dual_clock_fifo.DualClockFIFO`
(write side in the camera's domain, read side in ``sync``); the synchroniser pairs the two streams
frame by frame:

* **WAIT**: each FIFO independently drops words up to a ``sof`` (one per clock) and
  keeps a head ``sof``. When both heads are ``sof`` and both FIFOs hold at least
  ``threshold`` words (the thesis' N), the frame starts. A head ``sof`` whose FIFO
  is full, or holds more than ``max_skew`` words more than the other FIFO while the
  other head is not yet a ``sof``, belongs to a frame too old to pair (the other
  camera lost that frame): it is dropped, and that side drops on up to its next
  ``sof``.
* **FRAME**: whenever both FIFOs are non-empty, pop one word from each and emit the
  pair. The words' markers must match the raster position (x, y): ``sol`` exactly
  at x == 0, ``sof`` exactly at (0, 0). A mismatch (frame cut short, VSYNC inside a
  line, camera restarted: a ``sof`` too early; HREF glitch: a ``sol`` too early or
  missing) aborts the frame: it counts a fault and goes straight back to WAIT,
  popping nothing, so WAIT drops the damaged words and a head ``sof`` (the cut
  camera's next frame) starts the next frame at once. A full FIFO facing an empty
  one aborts the frame too: that camera overruns on its next word, so the frame is
  lost anyway (typically the other camera's frame was cut and its next ``sof`` is
  yet to come); aborting at once lets WAIT drain the full FIFO before that camera's
  next frame arrives, instead of the next frame overrunning as well. After the
  frame's last pixel pair: FLUSH (or WAIT when ``flush`` is 0).
* **FLUSH**: ``flush`` beats (payload 0, ``first`` 0), one per clock, then WAIT.

Output contract (the stream convention of :mod:`hdl._util` with the flush built in):

* every *completed* frame leaves as exactly ``width * height`` pixel beats in raster
  order (``first`` on the first; gaps when a FIFO runs empty), immediately followed
  by ``flush`` beats;
* an *aborted* frame leaves as a prefix of its pixel beats (starting with ``first``)
  and nothing else: no padding, no flush;
* ``valid`` is low between frames.

Why aborted frames are not padded to full size: every stage behind keeps its raster
position from the ``first`` marker, so the next ``first`` restarts it, and an
incomplete frame never reaches the centroid's last pixel, so it produces no record.
Padding would take up to ``width * height`` clocks, during which the cameras keep
writing the next frame: the FIFOs would have to hold a frame's worth of camera data
or that frame would be lost too. Without it the FIFOs only absorb the cameras'
phase difference, and the frame after a damaged one is paired normally.
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.validation import check_power_of_two

from ._util import KEEP_REGISTER, check_domain, check_geometry, check_int
from .camera_capture import capture_word_layout
from .dual_clock_fifo import DualClockFIFO

__all__ = ["StereoSynchronizer", "pixel_pair_layout", "check_fifo"]

FIFO_DEPTH_RANGE = (16, 65536)

#: The groups of registers the pairing decision steers, each decided from its
#: own copies of the state flags: each skid buffer, the output register, the
#: state and position, the frame/fault/stale counters.
DECISION_GROUPS = ("l_skid", "r_skid", "output", "state", "counters")
FLUSH_MAX = 1 << 20


def pixel_pair_layout() -> data.StructLayout:
    """Payload of the synchroniser's output: the left and right words of one pixel."""
    word = data.StructLayout({"luma": 8, "chroma": 8})
    return data.StructLayout({"first": 1, "left": word, "right": word})


def check_fifo(fifo_depth: int, threshold: int, pixels: int) -> tuple[int, int]:
    """``fifo_depth`` and ``threshold`` checked as :class:`StereoSynchronizer`
    checks them for frames of ``pixels`` pixels (without building it)."""
    fifo_depth = check_power_of_two("fifo_depth", fifo_depth, *FIFO_DEPTH_RANGE)
    return fifo_depth, check_int("threshold", threshold, 1, min(fifo_depth, pixels))


class StereoSynchronizer(wiring.Component):
    """Pairs the word streams of two captures into one pixel-pair stream (§5.3,
    Table 10).

    Parameters
    ----------
    width : int in [8, 4096], even
    height : int in [2, 4096]
    fifo_depth : power of two in [16, 65536]
        Words of each FIFO's RAM (absorbs the cameras' phase difference);
        :data:`~hdl.dual_clock_fifo.OUTPUT_WORDS` (3) more wait in the FIFO's
        output buffer and two in the skid buffer behind it.
    threshold : int in [1, min(fifo_depth, width*height)]
        N of the thesis: words both FIFOs must hold before a frame starts.
    max_skew : int in [1, fifo_depth], default ``fifo_depth // 2``
        Level difference beyond which a waiting ``sof`` is too old to pair.
        Must exceed the words the leading camera sends before the lagging one's
        ``sof`` arrives, and should be below ``width*height`` (otherwise only a full
        FIFO marks a lost frame).
    flush : int in [0, 2**20]
        Flush beats after every frame.
    left_domain, right_domain : str
        Clock domains of the captures (write sides of the FIFOs).

    Ports
    -----
    i_left : In(stream.Signature(capture_word_layout())), domain ``left_domain``;
        ``ready`` is the FIFO's ``w_rdy`` (low when full).
    i_right : likewise, domain ``right_domain``.
    o_stream : Out(stream.Signature(pixel_pair_layout(), always_ready=True)),
        domain ``sync``; payload ``{first, left: {luma, chroma}, right: {luma,
        chroma}}``, registered.
    frames : Out(16), frames completed (aborted ones not included), wrapping.
    faults : Out(16), frames aborted, wrapping.
    stale : Out(16), ``sof`` words dropped by the stale-frame rule, wrapping.

    Timing
    ------
    A pixel beat leaves one ``sync`` cycle after both words are at the heads
    (registered output). A written word reaches its FIFO's output register after
    the FIFO's two-flop Gray-pointer synchroniser, the registered Gray decode and
    the RAM read (four ``sync`` clock edges), and the head one edge later: each
    FIFO is followed by a two-word skid buffer, so that the pairing decision
    steers registers next to it (up to two words per side wait there, outside
    ``r_level``). The ``sync`` clock must pop faster than a camera writes (one
    word per two PCLK cycles while HREF is high), or the FIFOs fill and the
    captures overrun.
    """

    def __init__(self, width: int, height: int, fifo_depth: int = 1024, threshold: int = 64,
                 max_skew: int | None = None, flush: int = 0,
                 left_domain: str = "cam_left", right_domain: str = "cam_right"):
        self.width, self.height = check_geometry(width, height)
        if self.width % 2:
            raise ValueError(f"width must be even (4:2:2 pixel pairs) in [8, 4096], "
                             f"got {self.width}")
        self.fifo_depth, self.threshold = check_fifo(fifo_depth, threshold,
                                                     self.width * self.height)
        if max_skew is None:
            max_skew = self.fifo_depth // 2
        self.max_skew = check_int("max_skew", max_skew, 1, self.fifo_depth)
        self.flush = check_int("flush", flush, 0, FLUSH_MAX)
        self.left_domain = check_domain("left_domain", left_domain)
        self.right_domain = check_domain("right_domain", right_domain)
        word = stream.Signature(capture_word_layout())
        super().__init__({
            "i_left": In(word), "i_right": In(word),
            "o_stream": Out(stream.Signature(pixel_pair_layout(), always_ready=True)),
            "frames": Out(16), "faults": Out(16), "stale": Out(16),
        })

    def elaborate(self, platform):
        m = Module()
        w, h, depth = self.width, self.height, self.fifo_depth
        layout = capture_word_layout()

        fifos = []
        for side, port, domain in (("left", self.i_left, self.left_domain),
                                   ("right", self.i_right, self.right_domain)):
            fifo = DualClockFIFO(width=layout.size, depth=depth, w_domain=domain)
            m.submodules[f"fifo_{side}"] = fifo
            m.d.comb += [fifo.w_data.eq(port.payload), fifo.w_en.eq(port.valid),
                         port.ready.eq(fifo.w_rdy)]
            fifos.append(fifo)
        fl, fr = fifos

        # The state, one register per state, and the position of the next
        # pixel pair, as registered flags: the decision below reads registers
        # only (no counter comparison, no state decoding on its way).
        # `waiting` and `framing` are kept in one copy per group of registers
        # the decision steers (DECISION_GROUPS), each group decided from its
        # own copies: no decision net reaches all of them (routed on an ECP5,
        # the pair decision to ~150 registers: 3.6 + 2.2 ns of routing).
        waiting = [Signal(name=f"waiting_{g}", init=1, attrs=KEEP_REGISTER)
                   for g in DECISION_GROUPS]
        framing = [Signal(name=f"framing_{g}", attrs=KEEP_REGISTER) for g in DECISION_GROUPS]
        flushing = Signal(name="flushing")
        x = Signal(range(w))
        pixels_left = Signal(range(w * h))
        at_x0, at_first, at_last, x_last = (Signal(name=n) for n in (
            "at_x0", "at_first", "at_last", "x_last"))
        flush_left = Signal(range(self.flush + 1))
        # FIFO levels (two clocks late from the FIFO, registered once more here):
        # that only delays a start or a drop; full is the RAM and the output
        # buffer.
        full_l, full_r, ahead_l, ahead_r, filled = (Signal(name=n) for n in (
            "full_l", "full_r", "ahead_l", "ahead_r", "filled"))
        m.d.sync += [
            full_l.eq(fl.r_level == fl.capacity), full_r.eq(fr.r_level == fr.capacity),
            ahead_l.eq(fl.r_level > fr.r_level + self.max_skew),
            ahead_r.eq(fr.r_level > fl.r_level + self.max_skew),
            filled.eq((fl.r_level >= self.threshold) & (fr.r_level >= self.threshold)),
        ]

        # Behind each FIFO a two-word skid buffer: the decision pops these (next
        # to it), and only their registered fullness reaches the FIFO's read
        # enable. With it, a registered flag says whether the head's markers
        # fit the position of the next pair (`head_ok`).
        sides = []
        for side, fifo in (("left", fl), ("right", fr)):
            skid = {
                "valid": Signal(name=f"head_valid_{side}"),
                "head": Signal(layout, name=f"head_{side}", reset_less=True),
                "ok": Signal(name=f"head_ok_{side}"),
                "spare_valid": Signal(name=f"spare_valid_{side}"),
                "spare": Signal(layout, name=f"spare_{side}", reset_less=True),
                "take": Signal(name=f"take_{side}"),
                "fifo": fifo,
            }
            m.d.comb += [skid["take"].eq(fifo.r_rdy & ~skid["spare_valid"]),
                         fifo.r_en.eq(skid["take"])]
            sides.append(skid)
        left, right = sides

        # ---- the decision, once per group ----
        sof_l = left["valid"] & left["head"].sof
        sof_r = right["valid"] & right["head"].sof
        # a head whose markers do not fit (a sof too early, a sol too early or
        # missing), or a full FIFO facing an empty one (that side overruns on its
        # next word), aborts the frame
        bad = ((left["valid"] & ~left["ok"]) | (right["valid"] & ~right["ok"])
               | (full_l & ~right["valid"]) | (full_r & ~left["valid"]))

        def decide(g):
            """The decision from group ``g``'s copies of the state."""
            wait, frame = waiting[g], framing[g]
            # a side's head sof is stale when its FIFO is full or far ahead of
            # the other, whose head is not yet a sof: that frame has no partner
            d = {"stale_l": wait & sof_l & ~sof_r & (full_l | ahead_l),
                 "stale_r": wait & sof_r & ~sof_l & (full_r | ahead_r),
                 "start": wait & sof_l & sof_r & filled,
                 "pair": frame & left["valid"] & right["valid"] & ~bad,
                 "abort": frame & bad}
            for name, value in list(d.items()):
                d[name] = Signal(name=f"{name}_{g}")
                m.d.comb += d[name].eq(value)
            for skid, side in ((left, "l"), (right, "r")):
                d[f"pop_{side}"] = Signal(name=f"pop_{side}_{g}")
                m.d.comb += d[f"pop_{side}"].eq(
                    d["pair"] | (wait & skid["valid"] & ~skid["head"].sof) | d[f"stale_{side}"])
            return d

        decisions = {g: decide(i) for i, g in enumerate(DECISION_GROUPS)}

        # ---- skid buffers and their head_ok flags ----
        def fits(word, sol, sof):
            return (word.sol == sol) & (word.sof == sof)

        for skid, side in ((left, "l"), (right, "r")):
            d = decisions[f"{side}_skid"]
            start, pair, pop = d["start"], d["pair"], d[f"pop_{side}"]
            head, spare, fifo = skid["head"], skid["spare"], skid["fifo"]
            incoming = layout(fifo.r_data)
            with m.If(pop):
                with m.If(skid["spare_valid"]):
                    m.d.sync += [head.eq(spare), skid["spare_valid"].eq(0)]
                with m.Else():
                    m.d.sync += [head.eq(fifo.r_data), skid["valid"].eq(skid["take"])]
            with m.Elif(skid["take"]):
                with m.If(skid["valid"]):
                    m.d.sync += [spare.eq(fifo.r_data), skid["spare_valid"].eq(1)]
                with m.Else():
                    m.d.sync += [head.eq(fifo.r_data), skid["valid"].eq(1)]
            # the next head against the next position: each candidate word
            # against each candidate position, then chosen by the decision
            next_word = Mux(skid["spare_valid"], spare.as_value(), fifo.r_data)
            popped = layout(next_word)
            with m.If(start):
                m.d.sync += skid["ok"].eq(fits(head, 1, 1))
            with m.Elif(pair):
                m.d.sync += skid["ok"].eq(fits(popped, x_last, 0))
            with m.Elif(pop):
                m.d.sync += skid["ok"].eq(fits(popped, at_x0, at_first))
            with m.Elif(~skid["valid"]):
                m.d.sync += skid["ok"].eq(fits(incoming, at_x0, at_first))

        # ---- state, position, output ----
        hl, hr = left["head"], right["head"]
        out = self.o_stream
        pay = out.payload
        d = decisions["output"]
        m.d.sync += [out.valid.eq(d["pair"] | flushing), pay.eq(0)]
        with m.If(d["pair"]):
            m.d.sync += [
                pay.first.eq(at_first),
                pay.left.luma.eq(hl.luma), pay.left.chroma.eq(hl.chroma),
                pay.right.luma.eq(hr.luma), pay.right.chroma.eq(hr.chroma),
            ]
        d = decisions["counters"]
        with m.If(d["stale_l"] | d["stale_r"]):
            m.d.sync += self.stale.eq(self.stale + 1)
        with m.If(d["abort"]):
            m.d.sync += self.faults.eq(self.faults + 1)
        with m.If(d["pair"] & at_last):
            m.d.sync += self.frames.eq(self.frames + 1)
        d = decisions["state"]
        with m.If(d["start"]):
            m.d.sync += [[c.eq(0) for c in waiting], [c.eq(1) for c in framing],
                         x.eq(0), pixels_left.eq(w * h - 1), at_x0.eq(1), x_last.eq(0),
                         at_first.eq(1), at_last.eq(w * h == 1)]
        with m.If(d["abort"]):
            # abort: no padding, no flush; WAIT drops the damaged words and
            # keeps a head sof as the next frame's start
            m.d.sync += [[c.eq(0) for c in framing], [c.eq(1) for c in waiting]]
        with m.If(d["pair"]):
            m.d.sync += [
                x.eq(Mux(x_last, 0, x + 1)), at_x0.eq(x_last), x_last.eq(x == w - 2),
                at_first.eq(0), pixels_left.eq(pixels_left - 1),
                at_last.eq(pixels_left == 1),
            ]
            with m.If(at_last):
                m.d.sync += [flush_left.eq(self.flush), [c.eq(0) for c in framing]]
                m.d.sync += (flushing.eq(1) if self.flush else [c.eq(1) for c in waiting])
        with m.If(flushing):
            m.d.sync += flush_left.eq(flush_left - 1)
            with m.If(flush_left == 1):
                m.d.sync += [flushing.eq(0), [c.eq(1) for c in waiting]]
        return m
