"""One benchmark run: train an agent (`shoulder_bench.train`), score it on the fixed test set every `eval_every`
frames and at the end, and write the run folder (config.json, metrics.json, policy.pt, TensorBoard). It lives in
eval/ because scoring is evaluation: train/ never imports eval/."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from shoulder_bench.train.plan import ALGOS, algo_module, count, finished_metrics, plan

PAPER_PPO4_MAE = 5.15  # deg: "the paper's accuracy" for frames-to-accuracy (PPO-4, their model)
ACCURACY_DEG = (2.0, 1.0, 0.5)  # test MAE thresholds: frames and training wall time to the first evaluation at or below


def note_accuracy(run, mae_deg: float, training_s: float) -> None:
    """Record, for each threshold not reached before, the frames and training wall time (evaluations excluded) of
    this evaluation if its test MAE is at or below it; TensorBoard test/wall_s_to_<X>deg and test/frames_to_<X>deg."""
    for deg in ACCURACY_DEG:
        key = str(float(deg))
        if run.to_accuracy.get(key) is None and mae_deg <= deg:
            run.to_accuracy[key] = {"frames": run.frames, "wall_s": round(training_s, 3)}
            run.writer.add_scalar(f"test/wall_s_to_{deg:g}deg", training_s, run.frames)
            run.writer.add_scalar(f"test/frames_to_{deg:g}deg", run.frames, run.frames)
        run.to_accuracy.setdefault(key, None)


def curve_point(frames: int, training_s: float, m: dict) -> dict:
    """One test-set evaluation as metrics.json's `evaluations` lists it."""
    return {"frames": int(frames), "training_s": round(training_s, 3), "mae_deg": m["mae_deg"],
            "rmse_deg": m["rmse_deg"], "crashes": m["crashes"]}


def timed_evaluate(run, *args, **kwargs) -> tuple[dict, float]:
    """`evaluate(...)`, its wall time added to run.eval_s; also the training wall time before it."""
    from shoulder_bench.eval.evaluate import evaluate

    training_s, t = run.training_s(), time.perf_counter()
    m = evaluate(*args, **kwargs)
    run.eval_s += time.perf_counter() - t
    return m, training_s


def train(task: str, algo: str, frames: int | None = None, seed: int = 0, out: Path | None = None,
          resume: bool = False, config: Path | None = None, muscle_model: str | None = None,
          eval_every: int = 100_000, options: dict | None = None, init_from: str | None = None) -> dict:
    """Train, evaluate on the fixed test set, write the run folder; returns metrics.json's content. options: task
    options (delay_frames, obs_noise_deg, joint_damping, ...) the run trains and is evaluated with. init_from: a
    fine-tune, starting from this policy (policy.pt, a run folder, pretrained:NAME; `plan.init_source`), recorded
    in the run's identity as `init_from`; its frames count from 0. metrics.json's `evaluations` is every test-set
    evaluation (frames, training wall s, MAE, RMSE, crashes)."""
    import shoulder_bench
    from shoulder_bench.tasks import fixed_test_set
    from shoulder_bench.train.config import read_overrides
    from shoulder_bench.train.policy import save_policy
    from shoulder_bench.train.run import Run

    _, cls = algo_module(algo) if algo in ALGOS else (None, None)
    overrides = read_overrides(config, cls) if cls is not None else {}
    module, cfg, run_config = plan(task, algo, frames, seed, overrides, muscle_model,
                                   source=f"config file {config}" if config else "config", options=options)
    options = run_config["options"]
    init = None
    if init_from is not None:
        from shoulder_bench.train.plan import init_source

        run_config["init_from"], init = init_source(init_from, task, algo, run_config["muscle_model"])
    eval_every = count("--eval-every", eval_every)
    seed, frames, muscle_model = run_config["seed"], run_config["frames"], run_config["muscle_model"]
    if frames != run_config["frames_asked"]:
        print(f"budget: {run_config['frames_asked']:,} frames rounded up to {frames:,} "
              f"({frames // run_config['frames_per_iteration']} iterations of {run_config['frames_per_iteration']:,})")
    out = Path(out or Path("runs") / task / algo / str(seed))
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    done = finished_metrics(out, run_config) if resume else None
    if done is not None:  # nothing to do; opening the run again would start a new TensorBoard file
        return done
    # the simulator's rollout threads own the cores while stepping; torch's small matrices gain nothing from more
    # threads and OpenMP threads spinning against them cost 10x (measured: 34 s -> 3 s per PPO iteration)
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    np.random.seed(seed)
    with Run(out, run_config, resume) as run:
        venv = shoulder_bench.make_vec(task, cfg.num_envs, seed=seed * 100_000, muscle_model=muscle_model, **options)
        run.env = venv
        if run.checkpoint is not None and "env" in run.checkpoint["state"]:
            venv.load_state_dict(run.checkpoint["state"]["env"])
        elif run.checkpoint is not None:
            print(f"warning: {run.dir / 'checkpoint.pt'} predates exact resume (no env state): the episodes restart")
        test = fixed_test_set(task)

        def on_eval(policy) -> None:
            m, training_s = timed_evaluate(run, policy, task, test, muscle_model=muscle_model, options=options)
            run.writer.add_scalar("test/mae_deg", m["mae_deg"], run.frames)
            run.writer.add_scalar("test/rmse_deg", m["rmse_deg"], run.frames)
            run.writer.add_scalar("test/crashes", m["crashes"], run.frames)
            if run.paper_frames is None and m["mae_deg"] <= PAPER_PPO4_MAE:
                run.paper_frames = run.frames
                run.writer.add_scalar("test/wall_s_to_paper_accuracy", run.elapsed(), run.frames)
            note_accuracy(run, m["mae_deg"], training_s)
            run.evaluations.append(curve_point(run.frames, training_s, m))

        def evaluate_every(now: int) -> int:
            return (now // eval_every + 1) * eval_every

        run.start_progress(frames)
        try:
            policy = module.train(run, venv, cfg, frames, evaluate_every, on_eval,
                                  init=init if run.checkpoint is None else None)
        finally:
            venv.close()
        final, training_s = timed_evaluate(run, policy, task, test, muscle_model=muscle_model, options=options)
        note_accuracy(run, final["mae_deg"], training_s)  # the final evaluation counts too
        run.evaluations.append(curve_point(run.frames, training_s, final))
        metrics = {k: final[k] for k in ("mae_deg", "rmse_deg", "crashes", "n_trajectories")}
        metrics["per_trajectory"] = final["per_trajectory"]
        save_policy(policy, run.dir / "policy.pt",
                    {"task": task, "algo": algo, "seed": seed, "frames": run.frames, "muscle_model": muscle_model,
                     "options": run_config["options"], "model_version": run_config["model_version"],
                     "test": {k: metrics[k] for k in ("mae_deg", "rmse_deg", "crashes")}}
                    | ({"init_from": run_config["init_from"]} if "init_from" in run_config else {}))
        return run.finish(metrics)
