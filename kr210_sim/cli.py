"""Command-line interface: ``python -m kr210_sim <command>``."""

from __future__ import annotations

import argparse
import sys

from kr210_sim import __version__
from kr210_sim.errors import ConfigError, Kr210SimError


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """The CLI's argument parser."""
    parser = _Parser(prog="kr210_sim", description=__doc__)
    parser.add_argument("--version", action="version", version=f"kr210_sim {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    sub.required = True
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code (0 ok, 1 below the pass bar, 2 usage error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except ConfigError as exc:
        sys.stderr.write(f"kr210_sim: error: {exc}\n")
        return 2
    except Kr210SimError as exc:
        sys.stderr.write(f"kr210_sim: error: {exc}\n")
        return 2
