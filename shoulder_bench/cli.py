"""`shoulder-bench` command line: one subcommand per job; each module registers its own with `add_parser`."""
from __future__ import annotations

import argparse
import importlib
import sys

# modules that provide add_parser(subparsers); a missing optional one is skipped
COMMANDS = ["shoulder_bench.cli_tasks", "shoulder_bench.bench", "shoulder_bench.cli_train", "shoulder_bench.reproduce",
            "shoulder_bench.sweep", "shoulder_bench.eval.plots", "shoulder_bench.eval.leaderboard",
            "shoulder_bench.render", "shoulder_bench.fem.cli"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="shoulder-bench", description="Shoulder muscle-control benchmark.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (ValueError, KeyError, FileNotFoundError) as exc:  # errors a user can cause: say what and how to fix
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"shoulder-bench {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
