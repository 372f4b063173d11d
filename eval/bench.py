"""`shoulder-bench bench`: throughput measured side by side in one run (the machines are shared and noisy).

- batched: `make_vec(TASK, N)` (`--task`; default abduction_4m, track_3dof: the full shoulder) frames/s (a frame =
  0.1 s simulated) with random actions and auto-resets,
  over a window of one training episode (100 frames), so that every copy ends its episode and is reset once inside
  it (the resets are counted and printed);
- bare MuJoCo, two ways, each the same compiled model with fixed-gain actuators and no callback, stepped by
  `mujoco.rollout` with the same physics step, integrator and threads:
  "from rest": every copy from 45 deg at rest under a constant pull, the whole window in one call;
  "same states": one frame from each state the batched copies started a frame from in the window (all N x window
  frames in one call). MuJoCo's cost depends on the state (the constraint solver's iterations), and the muscles
  hold the batched copies in other states than the constant pull does, so this is the like-for-like reference:
  what the batched env costs beyond the physics of its own states. Both ratios are printed;
- the single gymnasium env in simulated seconds per wall second;
- peak resident memory of the process.
Ours and bare alternate (A, B, A, B, ...) and the best of the repeats is kept for each.
"""
from __future__ import annotations

import copy
import json
import resource
import time

import mujoco
import numpy as np
import torch
from mujoco import rollout

TASK = "abduction_4m"


def batched_rate(venv, frames: int, gen: torch.Generator, starts: list | None = None) -> tuple[float, int]:
    """Frames/s of the batched env over `frames` frames, and how many episodes ended (auto-reset) inside them.
    starts: a list that receives a copy of (qpos, qvel) each frame started from (the copies count in the timing)."""
    check_counts(frames=frames)
    n = venv.num_envs
    for _ in range(2):
        venv.step(torch.rand(n, venv.num_actions, generator=gen) * 0.02 - 0.01)
    resets = 0
    t = time.perf_counter()
    for _ in range(frames):
        if starts is not None:  # copies (a reset writes into the env's arrays); counted in the batched time
            starts.append((venv.qpos.copy(), venv.qvel.copy()))
        _, _, dones, _ = venv.step(torch.rand(n, venv.num_actions, generator=gen) * 0.02 - 0.01)
        resets += int(dones.sum())
    return n * frames / (time.perf_counter() - t), resets


def bare_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of `model` with plain fixed-gain actuators (force = ctrl) and no callback."""
    m = copy.copy(model)
    m.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    m.actuator_gainprm[:] = 0.0
    m.actuator_gainprm[:, 0] = 1.0
    m.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
    return m


def bare_same_states_rate(model: mujoco.MjModel, starts: list, nthread: int = 2) -> float:
    """Frames/s of plain MuJoCo (`bare_model`) advancing one frame from each recorded (qpos, qvel) start, all in one
    rollout call; controls 0 (the muscles' forces are left out with the callback; the states are what matter)."""
    m = bare_model(model)
    spf = max(1, int(round(0.1 / m.opt.timestep)))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    d = mujoco.MjData(m)
    s0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, s0, spec)
    qpos = np.concatenate([q for q, _ in starts])
    qvel = np.concatenate([v for _, v in starts])
    iq = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_TIME)  # FULLPHYSICS: time, qpos, qvel, ...
    state = np.tile(s0, (len(qpos), 1))
    state[:, iq:iq + m.nq], state[:, iq + m.nq:iq + m.nq + m.nv] = qpos, qvel
    ctrl = np.zeros((len(qpos), spf, m.nu))
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    with rollout.Rollout(nthread=nthread) as r:
        r.rollout(m, datas, state[:nthread], ctrl[:nthread])
        t = time.perf_counter()
        r.rollout(m, datas, state, ctrl)
        dt = time.perf_counter() - t
    return len(qpos) / dt


def bare_rate(n: int, frames: int, nthread: int = 2, task: str = TASK) -> tuple[float, float]:
    """Frames/s of plain MuJoCo on the task's model (fixed gains, no callback), and its physics step."""
    check_counts(num_envs=n, frames=frames, nthread=nthread)
    from shoulder_bench import full_arm
    from shoulder_bench.arm import arm, compile_arm
    from shoulder_bench.tasks import is_3dof

    three = is_3dof(task)  # the full shoulder's model (3 DOF, 15 tendons, 10 ms steps), else the v2 locked arm
    m = bare_model(full_arm.compile_full() if three else compile_arm())
    spf = max(1, int(round(0.1 / m.opt.timestep)))
    d = mujoco.MjData(m)
    d.qpos[:] = full_arm.Pose(m).qpos([45.0, 60.0, 0.0])[0] if three else arm().qpos(np.radians(45.0))[0]
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, s0, spec)
    state = np.tile(s0, (n, 1))
    ctrl = np.full((n, spf * frames, m.nu), -20.0)
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    with rollout.Rollout(nthread=nthread) as r:
        r.rollout(m, datas, state, ctrl[:, :spf])
        t = time.perf_counter()
        r.rollout(m, datas, state, ctrl)
        dt = time.perf_counter() - t
    return n * frames / dt, float(m.opt.timestep)


def gym_rate(seconds: float, task: str = TASK) -> float:
    import gymnasium as gym

    import shoulder_bench  # noqa: F401 (registers the ids)

    env = gym.make(f"ShoulderBench/{task}-v0", disable_env_checker=True)
    env.reset(seed=0)
    env.action_space.seed(0)
    steps, t = 0, time.perf_counter()
    while time.perf_counter() - t < seconds:
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        steps += 1
        if term or trunc:
            env.reset()
    return steps * 0.1 / (time.perf_counter() - t)


def check_counts(prefix: str = "", **counts) -> None:
    """Each count (repeats, copies, frames, threads) is a whole number of at least 1; checked before any work.
    prefix: "--" where the names are command-line options."""
    for name, value in counts.items():
        if not float(value).is_integer() or value < 1:
            raise ValueError(f"{prefix}{name} {value}: give a whole number of at least 1")


def run(args) -> int:
    import shoulder_bench
    from shoulder_bench.tasks import check_name

    check_counts("--", repeats=args.repeats)
    task = check_name(getattr(args, "task", None) or TASK)
    torch.set_num_threads(2)
    sizes = (16, 64) if args.quick else (64, 256, 1024, 4096)
    repeats = 1 if args.quick else args.repeats
    gen = torch.Generator().manual_seed(0)
    rows = []
    for n in sizes:
        venv = shoulder_bench.make_vec(task, n, seed=0)
        frames = venv.max_episode_length  # one training episode: every copy is reset once in the window
        ours, bare, same, resets = [], [], [], []
        for _ in range(repeats):
            starts = []
            fps, r = batched_rate(venv, frames, gen, starts)
            ours.append(fps)
            resets.append(r)
            b, step = bare_rate(n, frames, task=task)
            bare.append(b)
            same.append(bare_same_states_rate(venv.sim.model, starts))
        venv.close()
        rows.append({"num_envs": n, "batched_fps": max(ours), "bare_fps": max(bare),
                     "ratio": max(ours) / max(bare), "bare_same_states_fps": max(same),
                     "ratio_same_states": max(ours) / max(same), "physics_step_s": step, "window_frames": frames,
                     "resets": min(resets)})
    sim_rate = max(gym_rate(0.5 if args.quick else 3.0, task) for _ in range(repeats))
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"task {task}, physics step {rows[0]['physics_step_s'] * 1000:g} ms (RK4), 2 threads, best of {repeats}")
    print(f"window: {rows[0]['window_frames']} frames (one training episode) each, after 2 warm-up frames, so every "
          f"copy's episode ends and it is auto-reset once inside it (resets: fewest in a repeat)")
    print("bare MuJoCo frames/s: from rest (45 deg, constant pull, one call) | from the batched copies' own frame "
          "starts (one call)")
    print(f"{'N':>6} {'batched frames/s':>17} {'bare, from rest':>16} {'ratio':>6} {'bare, same states':>18} "
          f"{'ratio':>6} {'resets':>7}")
    for r in rows:
        print(f"{r['num_envs']:>6} {r['batched_fps']:>17,.0f} {r['bare_fps']:>16,.0f} {r['ratio']:>6.2f} "
              f"{r['bare_same_states_fps']:>18,.0f} {r['ratio_same_states']:>6.2f} {r['resets']:>7,}")
    print(f"single gymnasium env: {sim_rate:,.0f} simulated s per wall s")
    print(f"peak memory: {peak_mb:,.0f} MB")
    if args.json:
        print(json.dumps({"task": task, "rows": rows, "gym_sim_s_per_s": sim_rate, "peak_rss_mb": peak_mb}))
    return 0
