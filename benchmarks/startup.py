"""Start-up of the `tasks` and `eval` commands (issue 15 §5: start in <= 1.5 s), each as a fresh process.

    .venv/bin/python benchmarks/startup.py [--repeats 3]

Prints, best of `--repeats` (the commands alternate), the wall time of
- `shoulder-bench tasks`;
- `shoulder-bench eval --policy pretrained:ppo_4m --trajectories ONE.csv`: one 20 s trajectory (200 frames of one copy),
  so nearly all of it is start-up: the imports, the policy, the batched env;
- the same on the fixed test set (100 trajectories), the command as the README shows it;
and the imports alone (`python -c "import shoulder_bench.eval.evaluate, shoulder_bench.cli"`).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BIN = Path(sys.executable).parent


def wall(cmd: list[str]) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    cli = [str(BIN / "shoulder-bench")]
    with tempfile.TemporaryDirectory() as tmp:
        one = Path(tmp) / "one.csv"  # a 20 s ramp 30 -> 60 deg, 10 Hz
        t = np.arange(201) * 0.1
        np.savetxt(one, np.c_[t, 30.0 + 1.5 * t], delimiter=",", header="time_s,angle_deg", comments="", fmt="%.3f")
        commands = {"tasks": cli + ["tasks"],
                    "eval, one trajectory": cli + ["eval", "--policy", "pretrained:ppo_4m", "--trajectories", str(one)],
                    "eval, test set (100)": cli + ["eval", "--policy", "pretrained:ppo_4m"],
                    "imports only": [sys.executable, "-c", "import shoulder_bench.eval.evaluate, shoulder_bench.cli"]}
        best = {k: float("inf") for k in commands}
        for _ in range(max(1, args.repeats)):
            for name, cmd in commands.items():
                best[name] = min(best[name], wall(cmd))
    print(f"wall time of a fresh process, best of {args.repeats}")
    for name, s in best.items():
        print(f"{name:>22}: {s:6.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
