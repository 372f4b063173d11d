"""`shoulder-bench tasks` and `shoulder-bench demo` (the README's first command)."""
from __future__ import annotations

import time
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("tasks", help="list the tasks with a one-line description each")
    p.add_argument("--options", action="store_true",
                   help="list the task options instead: what each accepts and its default")
    p.set_defaults(func=_tasks)
    p = sub.add_parser("demo", help="the quick demo: train a small PPO agent, evaluate it, rank it on a leaderboard "
                                    "and render a video of it")
    p.add_argument("--task", default="abduction_4m")
    p.add_argument("--frames", type=int, default=200_000, help="PPO training frames")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--seconds", type=float, default=8.0, help="length of the video")
    p.add_argument("--out", type=Path, default=Path("runs/demo"))
    p.set_defaults(func=_demo)


def _tasks(args) -> int:
    from shoulder_bench.tasks import describe, list_tasks

    if getattr(args, "options", False):
        from shoulder_bench.tasks.options import DEFAULTS, OPTIONS

        width = max(map(len, OPTIONS))
        print("options of shoulder_bench.load, gymnasium.make, make_vec and gymnasium.make_vec (None: the task "
              "decides)")
        for name, accepts in OPTIONS.items():
            print(f"{name:<{width}}  {accepts}; default {DEFAULTS[name]!r}")
        return 0
    names = list_tasks()  # the 1-DOF tasks and the full shoulder's 3-DOF ones
    width = max(map(len, names))
    for name in names:
        print(f"{name:<{width}}  {describe(name)}")
    return 0


def _demo(args) -> int:
    """train -> evaluate -> leaderboard -> video, each step with a progress bar; everything lands in --out."""
    from shoulder_bench.eval import leaderboard
    from shoulder_bench.eval.experiment import train
    from shoulder_bench.eval.render import render_video
    from shoulder_bench.train.plan import check_task

    check_task(args.task, "ppo")  # before any work: the demo trains PPO
    if args.frames <= 0 or not args.seconds > 0:
        raise ValueError(f"--frames ({args.frames}) and --seconds ({args.seconds:g}) must be positive")
    if args.out.exists() and not args.out.is_dir():
        raise ValueError(f"--out {args.out} is a file; give a folder for the demo's outputs")
    t0 = time.perf_counter()
    run_dir = args.out / args.task / "ppo" / str(args.seed)
    print(f"[1/4] training PPO on {args.task} for {args.frames:,} frames -> {run_dir}")
    m = train(args.task, "ppo", frames=args.frames, seed=args.seed, out=run_dir, resume=True)
    print(f"[2/4] evaluated on the fixed test set (100 trajectories of 20 s): MAE {m['mae_deg']:.2f} deg, RMSE "
          f"{m['rmse_deg']:.2f} deg, crashes {m['crashes']}; {m['frames']:,} frames in {m['wall_s']:.0f} s of "
          f"training (the paper's PPO-4 on their model: MAE 5.15 deg, RMSE 6.64 deg)")
    print("[3/4] leaderboard: this run next to the shipped agents, the reference controller and the paper")
    board = leaderboard.write(leaderboard.collect(args.out, pretrained=True, progress=True), args.out / "leaderboard")
    print(board["md"].read_text())
    video = args.out / "demo.mp4"
    print(f"[4/4] rendering {args.seconds:g} s of the trained agent on a test target -> {video}")
    info = render_video(video, policy=str(run_dir), seconds=args.seconds, width=480, height=360, progress=True)
    print(f"\ndone in {time.perf_counter() - t0:.0f} s. Wrote:\n  {run_dir} (the run: policy.pt, metrics.json, "
          f"TensorBoard)\n  {board['md']}, {board['csv'].name}, {board['html'].name}\n  {info['path']} "
          f"({info['frames']} frames, {info['width']}x{info['height']}, MAE {info['mae_deg']:.2f} deg on its target)"
          f"\nnext: shoulder-bench eval --policy {run_dir} --trajectories combing")
    return 0
