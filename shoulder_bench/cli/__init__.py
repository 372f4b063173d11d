"""`shoulder-bench` command line: one subcommand (group) per module of this package, each registered by its
`add_parser`; the work itself lives in the layers below (tasks, train, eval, authoring)."""
from __future__ import annotations

import argparse
import gc
import importlib
import importlib.metadata
import signal
import sys
import threading

# modules that provide add_parser(subparsers); a missing optional one is skipped
COMMANDS = ["shoulder_bench.cli.tasks", "shoulder_bench.cli.bench", "shoulder_bench.cli.train",
            "shoulder_bench.cli.reproduce", "shoulder_bench.cli.sweep", "shoulder_bench.cli.plots",
            "shoulder_bench.cli.leaderboard", "shoulder_bench.cli.render", "shoulder_bench.cli.fem",
            "shoulder_bench.cli.validate", "shoulder_bench.cli.condition",
            "shoulder_bench.cli.surgery"]
# the subcommands each module registers (tests/test_cli_errors.py checks this against add_parser): a command line
# naming one of them imports only its module, so `tasks` or `eval` does not pay for torch, matplotlib or the
# renderer's imports of the other commands
REGISTERS = {"shoulder_bench.cli.tasks": ("tasks", "demo"), "shoulder_bench.cli.bench": ("bench",),
             "shoulder_bench.cli.train": ("train", "eval"), "shoulder_bench.cli.reproduce": ("reproduce",),
             "shoulder_bench.cli.sweep": ("sweep",), "shoulder_bench.cli.plots": ("plot",),
             "shoulder_bench.cli.leaderboard": ("leaderboard",), "shoulder_bench.cli.render": ("render",),
             "shoulder_bench.cli.fem": ("fem",), "shoulder_bench.cli.validate": ("model",),
             "shoulder_bench.cli.condition": ("condition",), "shoulder_bench.cli.surgery": ("surgery",)}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or (`command` one of them) of that command alone: what `main` parses with."""
    parser = argparse.ArgumentParser(prog="shoulder-bench", description="Shoulder muscle-control benchmark.")
    parser.add_argument("--version", action="version",
                        version=f"%(prog)s {importlib.metadata.version('shoulder-bench')}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    only = [m for m in COMMANDS if command in REGISTERS.get(m, ())]
    for name in only or COMMANDS:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue
            raise
        module.add_parser(sub)
    return parser


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM stops a command as Ctrl-C does: its cleanup runs, the exit code is 130


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser(argv[0] if argv else None).parse_args(argv)
    in_main = threading.current_thread() is threading.main_thread()  # signal handlers live in the main thread
    previous = signal.signal(signal.SIGTERM, _interrupt) if in_main else None
    try:
        return int(args.func(args) or 0)
    except (ValueError, KeyError, FileNotFoundError) as exc:  # errors a user can cause: say what and how to fix
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"shoulder-bench {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"shoulder-bench {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, previous)


def run() -> int:
    """The `shoulder-bench` program (its console script and `python -m shoulder_bench.cli`): `main` on sys.argv, in a
    process that exits after it. Start-up leaves ~3e5 long-lived objects (torch, numba, mujoco) and each full pass of
    the cyclic collector walks them all: `eval` made four during its imports and more at interpreter exit, ~0.5 s of a
    1.8 s run (benchmarks/startup.py). So full passes come after 100 young-generation passes instead of 10 (none in
    `eval`'s start-up), and what is alive when the command returns is frozen, left out of the passes at exit.
    `main`, as the tests call it, leaves the collector as it is."""
    young, middle, _ = gc.get_threshold()
    gc.set_threshold(young, middle, 100)
    try:
        return main()
    finally:
        gc.freeze()
