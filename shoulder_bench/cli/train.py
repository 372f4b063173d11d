"""`shoulder-bench train` and `shoulder-bench eval`: argument parsing; the run is `eval.experiment.train`."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from shoulder_bench.train.plan import ALGOS, DEFAULT_FRAMES


def add_parser(sub) -> None:
    p = sub.add_parser("train", help="train an agent; writes runs/<task>/<algo>/<seed>/")
    p.add_argument("--task", required=True)
    p.add_argument("--algo", required=True, choices=ALGOS)
    defaults = ", ".join(f"{a} {n:,}" for a, n in DEFAULT_FRAMES.items())
    p.add_argument("--frames", type=int, default=None,
                   help=f"frame budget (a frame = one 0.1 s step of one copy), rounded up to whole iterations; "
                        f"default: {defaults}")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/<task>/<algo>/<seed>)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out from its last checkpoint (same task, algo, seed, muscle model "
                        "and config; only --frames may grow)")
    p.add_argument("--config", type=Path, default=None, help="JSON file overriding the algorithm's config fields")
    p.add_argument("--muscle-model", default=None, help="fem or hill (default: the package default)")
    p.add_argument("--eval-every", type=int, default=100_000, help="frames between test-set evaluations")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="a task option the run trains and is evaluated with, e.g. delay_frames=1 (repeatable; part "
                        "of the run's identity; shoulder-bench tasks --options lists them)")
    p.add_argument("--condition", default=None, metavar="NAME",
                   help="a shoulder condition (ssp_tear, ld_transfer, ...; compose with '+'), the same as --option "
                        "condition=NAME; shoulder-bench condition report lists them")
    p.set_defaults(func=_train)
    p = sub.add_parser("eval", help="evaluate a policy on the test set or a trajectory CSV")
    p.add_argument("--policy", required=True,
                   help="policy.pt, a run folder, pretrained:NAME, or reference (the model-based controller)")
    p.add_argument("--task", default=None, help="default: the task the policy was trained on")
    p.add_argument("--trajectories", default=None, help="test (the fixed 100), combing, or a CSV file")
    p.add_argument("--suite", default=None,
                   help="a named, checksummed suite: paper (the default, = --trajectories test), fast (2-3 s "
                        "segments), wide (5-150 deg), adl (synthetic combing), robust (the paper set under "
                        "delay_frames=1, obs_noise_deg=0.5, strength +-20 %%, a 1 kg hand load, on top of the "
                        "policy's options); or a folder of CSV files (a hidden suite: every *.csv, sorted). On "
                        "track_3dof(_discrete): fast, adl (the four synthetic ADL profiles) and robust (the 3-DOF "
                        "test set under the same options) in three dimensions; "
                        "elevate_scapular_plane_12m: paper, fast, adl, robust in the scapular plane")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="a task option for this evaluation over the policy's own, e.g. delay_frames=1 or "
                        "obs_noise_deg=0.5 (repeatable; shoulder-bench tasks --options lists them)")
    p.add_argument("--condition", default=None, metavar="NAME",
                   help="a shoulder condition (ssp_tear, ld_transfer, ...; compose with '+'), the same as --option "
                        "condition=NAME; shoulder-bench condition report lists them")
    p.add_argument("--json", action="store_true", help="one JSON object on the last line")
    p.set_defaults(func=_eval)


def options_of(args) -> dict:
    """The task options of `--option KEY=VALUE ...` and `--condition NAME` (names checked here, values by the task)."""
    from shoulder_bench.tasks.options import assignments

    options = assignments(args.option)
    if args.condition is not None:
        if options.get("condition", args.condition) != args.condition:
            raise ValueError(f"--condition {args.condition} and --option condition={options['condition']}: give the "
                             "condition once")
        options["condition"] = args.condition
    return options


def _train(args) -> int:
    from shoulder_bench.eval import experiment

    options = options_of(args)  # names here, values in plan(), both before any work
    try:
        m = experiment.train(args.task, args.algo, args.frames, args.seed, args.out, args.resume, args.config,
                             args.muscle_model, args.eval_every, options=options)
    except KeyboardInterrupt:
        out = args.out or Path("runs") / args.task / args.algo / str(args.seed)
        kept = (Path(out) / "checkpoint.pt").exists()
        print("\ntrain: interrupted; " + (f"continue from the last checkpoint with the same command and --resume "
                                            f"(run folder {out})" if kept else "no checkpoint yet, nothing kept"),
              file=sys.stderr)
        return 130
    print(f"test set: MAE {m['mae_deg']:.2f} deg, RMSE {m['rmse_deg']:.2f} deg, crashes {m['crashes']}/"
          f"{m['n_trajectories']}; {m['frames']:,} frames in {m['wall_s']:.0f} s")
    reached = [f"{float(deg):g} deg " + (f"{r['wall_s']:.1f} s ({r['frames']:,} frames)" if r else "not reached")
               for deg, r in (m.get("to_accuracy") or {}).items()]
    if reached:  # runs finished before these were recorded have none
        print(f"training wall time (evaluations excluded, {m.get('eval_s', 0):.0f} s of them) to test MAE <= "
              + "; ".join(reached))
    return 0


def _eval(args) -> int:
    from shoulder_bench.eval.evaluate import evaluate, inference_latency_ms, policy_for, trajectories_for
    from shoulder_bench.tasks import check_options, is_3dof, spec

    # a trained policy without --task runs on its own task, which decides the trajectories (1-DOF or 3-DOF): loaded
    # first then, and only once
    loaded = policy_for(args.policy) if args.task is None and args.policy != "reference" else None
    hint = args.task if loaded is None else loaded[2]
    three = hint is not None and is_3dof(hint)
    extra = check_options(*([hint] if three else []), **options_of(args))  # fail before a given --task's policy loads
    from shoulder_bench.eval.suites import load_suite, options_for, suite_options

    if args.suite is not None and args.trajectories is not None:
        raise ValueError("give --suite or --trajectories, not both")
    # a 3-DOF task without --suite: --trajectories (default its test set, an ADL profile or a 3-DOF CSV)
    suite = None if args.trajectories is not None else args.suite or (None if three else "paper")
    if suite is None:
        label = args.trajectories or "test"
        trajs = trajectories_for(label, task=hint if three else None)
    else:
        options_for(suite, extra, who="--option")  # a conflict with the suite's options fails before any work
        trajs, label = load_suite(suite, task=hint if three else None), f"suite {suite}"
    policy, meta, task = loaded if loaded is not None else policy_for(args.policy, args.task, options=extra)
    options = dict(meta.get("options") or {}) | extra
    if suite is not None:  # the suite's task options on top of the policy's own (eval.suites.options_for)
        options = options_for(suite, options, who=f"policy {args.policy} (trained with it)")
        extra = extra | suite_options(suite)  # shown with the result
    m = evaluate(policy, task, trajs, muscle_model=meta.get("muscle_model"), options=options)
    for i, (mae, rmse, crashed) in enumerate(zip(*m["per_trajectory"].values())):
        print(f"trajectory {i:3d}: MAE {mae:6.2f} deg  RMSE {rmse:6.2f} deg{'  CRASHED' if crashed else ''}")
    m["latency_ms"] = inference_latency_ms(policy, (12 if is_3dof(task) else 4) + len(spec(task)[0]))
    print(f"overall on {m['n_trajectories']} trajectories ({label}"
          f"{''.join(f', {k}={v}' for k, v in extra.items())}): MAE {m['mae_deg']:.2f} deg, "
          f"RMSE {m['rmse_deg']:.2f} deg, crashes {m['crashes']}; inference {m['latency_ms']:.3f} ms per step "
          f"(batch 1, CPU)")
    if args.json:
        print(json.dumps({k: v for k, v in m.items() if k != "per_trajectory"} | {
            "task": task, "policy": args.policy, "options": options, "suite": suite,
            "suite_options": suite_options(suite) if suite is not None else {}}))
    return 0
