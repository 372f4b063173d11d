"""Simulated seconds per wall second: shoulder_bench's gymnasium env against MyoSuite's myoElbowPose1D6MRandom-v0.

Target: ShoulderBench/abduction_4m-v0 reaches at least 2x MyoSuite's elbow env, on one core.

Both envs are driven the same way: random actions from their action space, auto-reset when an episode ends, N steps
per measurement; simulated time = steps x the env's step duration (ours 0.1 s per frame, MyoSuite's read from
`env.unwrapped.dt`, 20 ms). Construction and a warm-up are excluded; resets inside the measurement are included.

MyoSuite pins gymnasium < 1.3, so it lives in its own virtual env. This script measures our env in-process and
MyoSuite's in a long-lived subprocess of that env's python (a small snippet passed with -c that waits for "measure
N" requests on stdin), and interleaves the two (ours, MyoSuite, ours, MyoSuite, ...) so that load from other
processes hits both. Rates are medians over the rounds; the CPU-time rates (process CPU seconds instead of wall
seconds) are printed too, as a check on load noise.

    python3 -m venv /tmp/myosuite-venv && /tmp/myosuite-venv/bin/pip install myosuite
    .venv/bin/python benchmarks/myosuite_compare.py [--steps 2000] [--rounds 3] [--cpu 0] [--json]
    taskset -c 0 .venv/bin/python benchmarks/myosuite_compare.py          # the same, pinned from outside

Exit status: 0 when the ratio reaches --target (default 2), 1 when it does not, 2 when MyoSuite cannot be run.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

DEFAULT_MYOSUITE_PYTHON = os.environ.get("MYOSUITE_PYTHON", "/tmp/myosuite-venv/bin/python")
OUR_ENV = "ShoulderBench/abduction_4m-v0"
MYO_ENV = "myoElbowPose1D6MRandom-v0"
SETUP_HINT = "python3 -m venv /tmp/myosuite-venv && /tmp/myosuite-venv/bin/pip install myosuite"

# Runs in the MyoSuite venv. Protocol: one JSON line {"ready": ..., "dt": ...} after construction and warm-up, then
# for every stdin line "N" one JSON line with the timing of N steps; ends at EOF. Anything the env prints goes to
# stderr, so stdout carries only the protocol.
MYO_SNIPPET = r'''
import json, os, sys, time
cpu = os.environ.get("BENCH_CPU")
if cpu:
    os.sched_setaffinity(0, {int(c) for c in cpu.split(",")})
out = sys.stdout
sys.stdout = sys.stderr
try:
    from myosuite.utils import gym
except ImportError:
    import gymnasium as gym
import myosuite  # noqa: F401  (registers the envs)
env = gym.make(sys.argv[1])
seed = int(sys.argv[2])
env.reset(seed=seed)
env.action_space.seed(seed)
dt = float(env.unwrapped.dt)

def run(n):
    resets = 0
    for _ in range(n):
        r = env.step(env.action_space.sample())
        if len(r) == 5:
            done = r[2] or r[3]
        else:
            done = r[2]
        if done:
            env.reset()
            resets += 1
    return resets

run(int(sys.argv[3]))  # warm-up
import gymnasium, mujoco
u = env.unwrapped
m = getattr(u, "model", None)
if not hasattr(m, "opt"):  # MyoSuite 2.x: env.sim.model
    m = getattr(getattr(u, "sim", None), "model", None)
print(json.dumps({"ready": True, "dt": dt, "myosuite": getattr(myosuite, "__version__", "?"),
                  "gymnasium": gymnasium.__version__, "mujoco": mujoco.__version__,
                  "timestep": float(m.opt.timestep) if hasattr(m, "opt") else None,
                  "integrator": int(m.opt.integrator) if hasattr(m, "opt") else None,
                  "frame_skip": getattr(u, "frame_skip", None)}), file=out, flush=True)
for line in sys.stdin:
    n = int(line)
    w0, c0 = time.perf_counter(), time.process_time()
    resets = run(n)
    w1, c1 = time.perf_counter(), time.process_time()
    print(json.dumps({"steps": n, "wall": w1 - w0, "cpu": c1 - c0, "resets": resets}), file=out, flush=True)
'''


class OurEnv:
    def __init__(self, env_id: str, seed: int, warmup: int):
        import gymnasium

        import shoulder_bench  # noqa: F401  (registers the gymnasium ids)

        self.env = gymnasium.make(env_id)
        self.env.reset(seed=seed)
        self.env.action_space.seed(seed)
        inner = self.env.unwrapped
        try:
            self.dt = float(inner.env.control_timestep())
        except AttributeError:
            from shoulder_bench import protocol

            self.dt = protocol.FRAME_S
        physics = inner.env.physics
        self.timestep = float(physics.model.opt.timestep)
        self.run(warmup)

    def run(self, n: int) -> int:
        env, sample, resets = self.env, self.env.action_space.sample, 0
        for _ in range(n):
            _, _, terminated, truncated, _ = env.step(sample())
            if terminated or truncated:
                env.reset()
                resets += 1
        return resets

    def measure(self, n: int) -> dict:
        w0, c0 = time.perf_counter(), time.process_time()
        resets = self.run(n)
        w1, c1 = time.perf_counter(), time.process_time()
        return {"steps": n, "wall": w1 - w0, "cpu": c1 - c0, "resets": resets}


class MyoSuiteEnv:
    def __init__(self, python: str, env_id: str, seed: int, warmup: int, cpu: str | None):
        env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
                   PYTHONUNBUFFERED="1")
        if cpu:
            env["BENCH_CPU"] = cpu
        self.proc = subprocess.Popen([python, "-c", MYO_SNIPPET, env_id, str(seed), str(warmup)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=env)
        self.info = self._read()
        self.dt = float(self.info["dt"])

    def _read(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            err = self.proc.stderr.read()
            self.proc.wait()
            raise RuntimeError(f"the MyoSuite process ended (exit {self.proc.returncode}):\n{err[-4000:]}")
        return json.loads(line)

    def measure(self, n: int) -> dict:
        self.proc.stdin.write(f"{n}\n")
        self.proc.stdin.flush()
        return self._read()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def summarise(runs: list[dict], dt: float) -> dict:
    wall = [r["steps"] * dt / r["wall"] for r in runs]
    cpu = [r["steps"] * dt / r["cpu"] for r in runs if r["cpu"] > 0]
    return {"dt_s": dt, "steps_per_round": runs[0]["steps"], "rounds": len(runs),
            "sim_s_per_wall_s": statistics.median(wall), "sim_s_per_wall_s_all": [round(x, 2) for x in wall],
            "sim_s_per_cpu_s": statistics.median(cpu) if cpu else None,
            "steps_per_wall_s": statistics.median(r["steps"] / r["wall"] for r in runs),
            "resets": sum(r["resets"] for r in runs)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--myosuite-python", default=DEFAULT_MYOSUITE_PYTHON,
                   help=f"python of the MyoSuite venv (default {DEFAULT_MYOSUITE_PYTHON}; env MYOSUITE_PYTHON)")
    p.add_argument("--env", default=OUR_ENV)
    p.add_argument("--myosuite-env", default=MYO_ENV)
    p.add_argument("--steps", type=int, default=2000, help="our env steps per round (0.1 s each)")
    p.add_argument("--myosuite-steps", type=int, default=None,
                   help="MyoSuite steps per round (default: the same simulated time as ours)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--warmup", type=int, default=100, help="steps before timing, per env")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--cpu", default=None, help="pin both processes to these CPUs, e.g. 0 (one core)")
    p.add_argument("--target", type=float, default=2.0)
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    args = p.parse_args(argv)

    python = Path(args.myosuite_python)
    if not python.exists():
        print(f"MyoSuite venv not found: {python} does not exist.\n"
              f"Create it with:\n    {SETUP_HINT}\n"
              f"or point --myosuite-python (or MYOSUITE_PYTHON) at the python of an env with myosuite installed.",
              file=sys.stderr)
        return 2
    if args.cpu:
        os.sched_setaffinity(0, {int(c) for c in args.cpu.split(",")})

    try:
        myo = MyoSuiteEnv(str(python), args.myosuite_env, args.seed, args.warmup, args.cpu)
    except (RuntimeError, json.JSONDecodeError, OSError) as exc:
        print(f"could not start {args.myosuite_env} with {python}: {exc}\n"
              f"(is myosuite installed there? {SETUP_HINT})", file=sys.stderr)
        return 2
    try:
        ours = OurEnv(args.env, args.seed, args.warmup)
        myo_steps = args.myosuite_steps or max(1, round(args.steps * ours.dt / myo.dt))
        our_runs, myo_runs = [], []
        for k in range(args.rounds):  # A, B, A, B, ...: load drifts hit both
            our_runs.append(ours.measure(args.steps))
            myo_runs.append(myo.measure(myo_steps))
            print(f"  round {k + 1}/{args.rounds}: ours {args.steps * ours.dt / our_runs[-1]['wall']:8.1f}  "
                  f"myosuite {myo_steps * myo.dt / myo_runs[-1]['wall']:8.1f}  sim s / wall s", file=sys.stderr)
    finally:
        myo.close()

    a, b = summarise(our_runs, ours.dt), summarise(myo_runs, myo.dt)
    ratio = a["sim_s_per_wall_s"] / b["sim_s_per_wall_s"]
    per_round = [(ra["steps"] * ours.dt / ra["wall"]) / (rb["steps"] * myo.dt / rb["wall"])
                 for ra, rb in zip(our_runs, myo_runs)]
    cpu_ratio = (a["sim_s_per_cpu_s"] / b["sim_s_per_cpu_s"]) if a["sim_s_per_cpu_s"] and b["sim_s_per_cpu_s"] \
        else None
    ok = ratio >= args.target

    print(f"{'':28} {args.env:>32} {args.myosuite_env:>28}")
    print(f"{'step (sim s)':28} {ours.dt:32.3f} {myo.dt:28.3f}")
    print(f"{'physics timestep (s)':28} {ours.timestep:32.4f} {str(myo.info.get('timestep')):>28}")
    print(f"{'steps per round x rounds':28} {f'{args.steps} x {args.rounds}':>32} {f'{myo_steps} x {args.rounds}':>28}")
    print(f"{'env steps / wall s':28} {a['steps_per_wall_s']:32.1f} {b['steps_per_wall_s']:28.1f}")
    print(f"{'sim s / wall s (median)':28} {a['sim_s_per_wall_s']:32.1f} {b['sim_s_per_wall_s']:28.1f}")
    print(f"{'sim s / CPU s (median)':28} {a['sim_s_per_cpu_s'] or float('nan'):32.1f} "
          f"{b['sim_s_per_cpu_s'] or float('nan'):28.1f}")
    print(f"ratio (ours / MyoSuite, wall): {ratio:.2f}x  per round: {', '.join(f'{r:.2f}' for r in per_round)}"
          + (f"  (CPU time: {cpu_ratio:.2f}x)" if cpu_ratio else "")
          + f"  target {args.target:g}x: {'met' if ok else 'NOT met'}"
          + (f"  [pinned to CPU {args.cpu}]" if args.cpu else ""))
    if args.json:
        print(json.dumps({"ours": {"env": args.env, **a}, "myosuite": {"env": args.myosuite_env, **b,
                          "versions": {k: myo.info.get(k) for k in ("myosuite", "gymnasium", "mujoco")}},
                          "ratio": ratio, "ratio_per_round": per_round, "ratio_cpu": cpu_ratio,
                          "target": args.target, "met": ok, "cpu": args.cpu,
                          "affinity": sorted(os.sched_getaffinity(0))}))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
