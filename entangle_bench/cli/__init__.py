"""Command-line interface: `main(argv)` dispatches to one module per subcommand.

The library raises typed exceptions; only this layer prints them and sets the exit code.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys

from entangle_bench.cli.interrupt import Interrupted, terminate_as_exception
from entangle_bench.errors import EntangleBenchError

# Subcommand name -> module under entangle_bench.cli exposing `add_parser(subparsers)` and `run(args)`.
SUBCOMMANDS: dict[str, str] = {
    "acn": "acn",
    "run": "run",
    "tasks": "tasks",
    "objects": "objects",
    "rod": "rod",
    "compare": "compare",
    "references": "references",
    "describe": "describe",
    "report": "report",
}


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level argument parser with every subcommand attached."""
    parser = argparse.ArgumentParser(
        prog="entangle-bench", description="Benchmark harness for entanglement grasping."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for module_name in SUBCOMMANDS.values():
        module = importlib.import_module(f"entangle_bench.cli.{module_name}")
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the process exit code (0 ok, 1 some trials failed, 2 bad input, 130/143 SIGINT/SIGTERM)."""
    args = build_parser().parse_args(argv)
    try:
        with terminate_as_exception():
            return int(args.run(args) or 0)
    except EntangleBenchError as exc:
        print(f"entangle-bench: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and closed early
        return 0
    except KeyboardInterrupt:
        print("entangle-bench: interrupted (SIGINT)", file=sys.stderr)
        return 128 + signal.SIGINT
    except Interrupted as exc:
        print(f"entangle-bench: interrupted ({signal.Signals(exc.signum).name})", file=sys.stderr)
        return 128 + exc.signum


if __name__ == "__main__":
    sys.exit(main())
