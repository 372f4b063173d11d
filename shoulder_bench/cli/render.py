"""`shoulder-bench render`: the arguments of `eval.render.render_video`."""
from __future__ import annotations

from pathlib import Path

from shoulder_bench.eval.render import CAMERAS, render_video


def add_parser(sub) -> None:
    p = sub.add_parser("render", help="render a headless video of one episode (mp4, or --gif)",
                       description="Render one episode: bones as meshes, muscles coloured by activation, a "
                                   "translucent ghost arm at the target angle and an overlay with time, angle and "
                                   "target. Without --policy the PD feedback controller drives the arm.")
    p.add_argument("--task", default=None,
                   help="task name (default: the policy's task, else abduction_4m); see `shoulder-bench tasks`")
    p.add_argument("--policy", default=None,
                   help="policy.pt, a run folder, pretrained:NAME, or reference (the model-based controller); "
                        "default: the PD feedback controller")
    p.add_argument("--trajectory", type=Path, default=None,
                   help="CSV target (time_s,angle_deg[,trajectory]; the first trajectory is used); default: a "
                        "random test-split target drawn with --seed")
    p.add_argument("--out", type=Path, required=True, help="output file (.mp4; .gif with --gif)")
    p.add_argument("--seconds", type=float, default=None, help="length of the video (default: the whole target)")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--fps", type=int, default=None, help="frames per second (default 30 for mp4, 20 for GIF)")
    p.add_argument("--gif", action="store_true", help="write an animated GIF instead of an mp4")
    p.add_argument("--camera", choices=CAMERAS, default="front")
    p.add_argument("--seed", type=int, default=0, help="seed of the random target")
    p.add_argument("--condition", default=None, metavar="NAME",
                   help="a shoulder condition (ssp_tear, ld_transfer, ...; compose with '+'): the episode runs "
                        "post-op; the video shows its geometry (ld_transfer: the rerouted latissimus) and its "
                        "removed muscles in grey")
    p.add_argument("--multisample", action="store_true",
                   help="4x multisampling: smoother edges, about half the frame rate on a CPU (default off)")
    p.set_defaults(func=_render_cmd)


def _render_cmd(args) -> int:
    info = render_video(args.out, task=args.task, policy=args.policy, trajectory=args.trajectory,
                        seconds=args.seconds, width=args.width, height=args.height, gif=args.gif, fps=args.fps,
                        camera=args.camera, seed=args.seed, progress=True,
                        multisample=args.multisample, condition=args.condition)
    print(f"wrote {info['path']}: {info['frames']} frames, {info['width']}x{info['height']} at {info['fps']} fps "
          f"({info['seconds']:.1f} s of {info['task']} with {info['controller']}; MAE {info['mae_deg']:.2f} deg"
          f"{', CRASHED' if info['crashed'] else ''}); {info['render_fps']:.0f} frames rendered per wall second")
    return 0
