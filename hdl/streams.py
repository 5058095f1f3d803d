"""Wiring of streams whose payloads differ (each stage names its payload fields
after what they hold: ``pixel``, ``disparity``, ``hand``, ...), so that a
pipeline reads as one line per connection instead of one per field."""
from __future__ import annotations

from amaranth.lib import data, stream

__all__ = ["pixel_signature", "connect_remapped"]


def pixel_signature(pixel_bits: int, *, real: bool = False) -> stream.Signature:
    """The stream of one ``pixel_bits``-bit pixel per beat that window stages take
    and give (always ready): ``{first, pixel}`` into a stage, ``{first, real,
    pixel}`` out of one (``real``: the beat's position lies inside the frame;
    see the stream convention in :mod:`hdl`). One definition, so neighbours with
    the same fields connect with :func:`amaranth.lib.wiring.connect`."""
    fields = {"first": 1, "real": 1, "pixel": pixel_bits} if real else \
        {"first": 1, "pixel": pixel_bits}
    return stream.Signature(data.StructLayout(fields), always_ready=True)


def connect_remapped(m, source, sink, **fields):
    """Drive stream ``sink`` from stream ``source`` in ``m``'s combinational domain.

    ``valid`` follows the source (and ``ready`` the sink, unless the source is
    always ready); each field of the sink's payload takes ``fields[name]`` (any
    value: another stream's field, an expression) or else the source payload's
    field of the same name.

    Raises
    ------
    ValueError
        Naming a sink field with no value, or a keyword that is no sink field.
    """
    members = sink.payload.shape().members
    unknown = sorted(set(fields) - set(members))
    if unknown:
        raise ValueError(f"the sink's payload has no field {', '.join(unknown)} "
                         f"(it has {', '.join(members)})")
    source_members = getattr(source.payload.shape(), "members", {})
    statements = [sink.valid.eq(source.valid)]
    if not source.signature.always_ready:
        statements.append(source.ready.eq(sink.ready))
    for name in members:
        if name in fields:
            value = fields[name]
        elif name in source_members:
            value = getattr(source.payload, name)
        else:
            raise ValueError(f"the sink's payload field {name!r} has no value: the source "
                             f"has no such field and none was given")
        statements.append(getattr(sink.payload, name).eq(value))
    m.d.comb += statements
