"""Directives that render the project's one definitions into the site:

``.. register-map:: NAME``
    the register map ``NAME`` of :mod:`soc.hps_interface` (``fifo``, ``uart``,
    ``posture``) as a table, with the slave's base on the bridge.

``.. cli-reference:: MODULE:FUNCTION``
    the help of an argparse parser that ``FUNCTION`` builds, as ``--help``
    prints it (80 columns), and a section per subcommand with its own.
"""
from __future__ import annotations

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective


class RegisterMapDirective(SphinxDirective):
    required_arguments = 1

    def run(self):
        from soc import hps_interface as hps
        maps = {m.name: m for m in (hps.FIFO_REGISTERS, hps.UART_REGISTERS,
                                     hps.POSTURE_REGISTERS)}
        name = self.arguments[0]
        if name not in maps:
            raise self.error(f"register-map: {name!r} is not one of {sorted(maps)}")
        regmap = maps[name]
        base = hps.LIGHTWEIGHT_BRIDGE_BASE + hps.SLAVE_BASES[name]
        text = [f"Base {base:#010x} (bridge offset {hps.SLAVE_BASES[name]:#05x}), "
                f"{regmap.span:#x} bytes decoded.", ""] + regmap.table().splitlines()
        node = nodes.section()
        self.state.nested_parse(StringList(text, source=f"soc/hps_interface.py:{name}"),
                                self.content_offset, node)
        return node.children


class CliReferenceDirective(SphinxDirective):
    required_arguments = 1

    def run(self):
        import argparse
        import importlib
        import os
        module, _, function = self.arguments[0].partition(":")
        parser = getattr(importlib.import_module(module), function)()
        os.environ["COLUMNS"] = "80"      # the width argparse wraps to
        try:
            out = [nodes.literal_block(text=parser.format_help())]
            subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
            for action in subs:
                for name, sub in action.choices.items():
                    section = nodes.section(ids=[nodes.make_id(f"{parser.prog} {name}")])
                    section += nodes.title(text=f"{parser.prog} {name}")
                    section += nodes.literal_block(text=sub.format_help())
                    out.append(section)
        finally:
            del os.environ["COLUMNS"]
        return out


def setup(app):
    app.add_directive("register-map", RegisterMapDirective)
    app.add_directive("cli-reference", CliReferenceDirective)
    return {"parallel_read_safe": True, "version": "1"}
