"""The MJX backend's one prepared GPU check (issue 15 §4): frames/s of `abduction_4m` at N = 1024 ... 65,536 on the
JAX device, the CPU MuJoCo backend at 1024 for the ratio, and PPO-4 wall time to 0.5 deg test MAE, as one table.

    python benchmarks/gpu.py                 # on a machine with a GPU and the [mjx] extra (installs nothing)
    python benchmarks/gpu.py --quick         # on the CPU: small N, a tiny PPO budget (what the tests can afford)

frames/s: random actions within +-1 %/frame with auto-resets (as `shoulder-bench bench`), the first steps (JAX
compilation) timed apart as `compile_s`. PPO-4: `train.ppo.train` (the training driver, default `PPOConfig` unless
--ppo-envs) on the MJX env, the exported policy scored on the fixed test set by `eval.evaluate.evaluate` (the CPU MuJoCo
backend, the official scorer) every --eval-every frames; wall time excludes the evaluations, as `train` counts it.
"""
from __future__ import annotations

import argparse
import copy
import time

import numpy as np
import torch

import shoulder_bench
from shoulder_bench.eval.evaluate import evaluate
from shoulder_bench.mjx_sim import DEFAULT_DTYPE
from shoulder_bench.tasks import mjx_env
from shoulder_bench.train import ppo
from shoulder_bench.trajectory import load_test_set

TASK = "abduction_4m"


def sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def throughput(make, n: int, frames: int, device: torch.device, warmup: int = 3) -> tuple[float, float]:
    """(frames/s, seconds of the first `warmup` steps) of env `make(n)` stepping random actions."""
    gen = torch.Generator(device=device).manual_seed(0)
    t = time.perf_counter()
    venv = make(n)
    for _ in range(warmup):
        venv.step((torch.rand((n, 4), generator=gen, device=device) * 2 - 1) * 0.01)
    sync(device)
    first = time.perf_counter() - t
    t = time.perf_counter()
    for _ in range(frames):
        venv.step((torch.rand((n, 4), generator=gen, device=device) * 2 - 1) * 0.01)
    sync(device)
    rate = n * frames / (time.perf_counter() - t)
    venv.close()
    return rate, first


class BenchRun:
    """What `train.ppo.train` needs of a run (`train.run.Run`): frame count, returns, no folder or checkpoints."""

    checkpoint = None

    def __init__(self):
        self.frames, self.returns, self.eval_s = 0, [], 0.0
        self._t0 = time.perf_counter()

    def advance(self, frames: int, scalars: dict) -> None:
        self.frames += frames

    def save_checkpoint(self, state: dict) -> None:
        pass

    def training_s(self) -> float:
        return time.perf_counter() - self._t0 - self.eval_s


class Reached(Exception):
    pass


def ppo_to_accuracy(device: torch.device, num_envs: int | None, budget: int, eval_every: int, target: float,
                    test_size: int, seed: int = 0) -> dict:
    """Train PPO-4 on the MJX env until the test MAE is <= target (or the budget is spent)."""
    cfg = ppo.PPOConfig() if num_envs is None else ppo.PPOConfig(num_envs=num_envs)
    torch.manual_seed(seed)
    venv = mjx_env.make(TASK, cfg.num_envs, device=str(device), seed=seed * 100_000)
    test = load_test_set()[:test_size]
    run, best = BenchRun(), {"mae_deg": float("inf"), "frames": 0, "training_s": None}

    def on_eval(policy) -> None:
        t = time.perf_counter()
        mae = evaluate(copy.deepcopy(policy).cpu(), TASK, test)["mae_deg"]
        training_s = run.training_s()
        run.eval_s += time.perf_counter() - t
        print(f"  PPO-4 on MJX: {run.frames:,} frames, {training_s:.1f} s training, test MAE {mae:.3f} deg",
              flush=True)
        if mae < best["mae_deg"]:
            best.update(mae_deg=mae, frames=run.frames, training_s=training_s)
        if mae <= target:
            raise Reached

    # train.ppo.train builds rsl-rl's runner on "cpu"; the networks must live where the env's tensors are
    runner = ppo.OnPolicyRunner
    ppo.OnPolicyRunner = lambda env, config, log_dir=None, device=None: runner(env, config, log_dir, str(venv.device))
    try:
        ppo.train(run, venv, cfg, budget, lambda now: (now // eval_every + 1) * eval_every, on_eval)
    except Reached:
        pass
    finally:
        ppo.OnPolicyRunner = runner
        venv.close()
    return {**best, "reached": best["mae_deg"] <= target, "num_envs": cfg.num_envs, "dtype": venv.dtype}


def rate_text(rate: float) -> str:
    return f"{rate:,.0f}" if rate >= 100 else f"{rate:.2g}"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="CPU-sized: N = 16, 64; 2 timed frames; a tiny PPO budget")
    p.add_argument("--device", default=None, help="default: cuda if torch sees a GPU, else cpu")
    p.add_argument("--sizes", type=int, nargs="+", default=None, help="default 1024 4096 16384 65536")
    p.add_argument("--frames", type=int, default=None, help="timed frames per size (default 20; --quick 2)")
    p.add_argument("--ppo-frames", type=int, default=None, help="PPO budget (default 3,000,000; --quick 12,288)")
    p.add_argument("--ppo-envs", type=int, default=None, help="PPO copies (default PPOConfig's; --quick 64)")
    p.add_argument("--eval-every", type=int, default=None, help="frames between test-set scores (default 100,000)")
    p.add_argument("--target-mae", type=float, default=0.5)
    p.add_argument("--test-size", type=int, default=100, help="test trajectories per score (default all 100)")
    p.add_argument("--skip-ppo", action="store_true")
    a = p.parse_args()
    device = torch.device(a.device or ("cuda" if torch.cuda.is_available() else "cpu"))
    sizes = a.sizes or ([16, 64] if a.quick else [1024, 4096, 16384, 65536])
    frames = a.frames or (2 if a.quick else 20)
    ref_n = sizes[0] if a.quick else 1024
    torch.set_num_threads(1)
    rows = []
    ref, ref_first = throughput(lambda n: shoulder_bench.make_vec(TASK, n, seed=0), ref_n, frames, torch.device("cpu"))
    rows.append(("mujoco", "cpu", ref_n, "float64", ref_first, ref))
    print(f"mujoco cpu N={ref_n}: {ref:,.0f} frames/s", flush=True)
    for n in sizes:
        rate, first = throughput(lambda k: mjx_env.make(TASK, k, device=str(device), seed=0), n, frames, device)
        rows.append(("mjx", str(device), n, DEFAULT_DTYPE, first, rate))  # mjx_env's default
        print(f"mjx {device} N={n}: {rate_text(rate)} frames/s (first 3 steps {first:.1f} s)", flush=True)
    result = None
    if not a.skip_ppo:
        result = ppo_to_accuracy(device, a.ppo_envs or (64 if a.quick else None),
                                 a.ppo_frames or (12_288 if a.quick else 3_000_000),
                                 a.eval_every or (6_144 if a.quick else 100_000), a.target_mae,
                                 4 if a.quick else a.test_size)
    gpu = torch.cuda.get_device_name(device) if device.type == "cuda" else "none (CPU)"
    print(f"\n{TASK}; GPU: {gpu}; {time.strftime('%Y-%m-%d')}")
    print(f"| backend | device | N | dtype | first 3 steps s | frames/s | x mujoco cpu N={ref_n} |")
    print("|---|---|---:|---|---:|---:|---:|")
    for backend, dev, n, dtype, first, rate in rows:
        print(f"| {backend} | {dev} | {n:,} | {dtype} | {first:.1f} | {rate_text(rate)} | {rate / ref:.2g} |")
    if result is not None:
        state = "reached" if result["reached"] else "NOT reached"
        wall = "-" if result["training_s"] is None else f"{result['training_s']:.1f} s"
        print(f"\nPPO-4 on mjx {device} ({result['dtype']}, {result['num_envs']} copies): test MAE <= "
              f"{a.target_mae} deg {state}; best {result['mae_deg']:.3f} deg at {result['frames']:,} frames, "
              f"training wall time {wall}")
    np.set_printoptions()


if __name__ == "__main__":
    main()
