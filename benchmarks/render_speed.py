"""Render frame rate with and without multisampling, side by side in one run (issue: >= 70 frames/s at 480 x 360).

    MUJOCO_GL=egl .venv/bin/python benchmarks/render_speed.py [--frames 200] [--width 480] [--height 360] [--repeats 3]
    MUJOCO_GL=egl .venv/bin/python benchmarks/render_speed.py --pipeline [...]

Renders the same poses (the arm sweeping 0-150 deg, the ghost opposite) with `eval.render_model`'s model and MuJoCo's
`Renderer`, alternating the two settings `--repeats` times, and prints the best frames/s of each and their ratio.
The overlay and the video encoder (`shoulder-bench render` adds them) are not included: this is the 3-D frame only.

--pipeline: instead, without multisampling, the 3-D frame (drawn and read back) alone, with `eval.render`'s overlay
drawn on it (time, angles and the activations changing as in a 30 fps video of 0.1 s steps), and with the overlay and
the H.264 encoder too (`eval.render.Mp4Writer` to a temporary file; the encoder's final flush not timed, as
`shoulder-bench render` counts it), interleaved `--repeats` times: the best frames/s of each and
their ratio to the 3-D frame alone.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

STAGES = ("frame", "overlay", "mp4")  # --pipeline: the 3-D frame; + the overlay; + the overlay and the encoder
STAGE_LABELS = {"frame": "3-D frame (drawn, read back)", "overlay": "+ overlay",
                "mp4": "+ overlay + H.264 encoder (whole per-frame path)"}


def frames_per_second(multisample: bool, frames: int, width: int, height: int, stage: str = "frame") -> float:
    """Frames/s of drawing and reading back `frames` poses; stage "overlay" adds `eval.overlay.Overlay` on each frame,
    "mp4" also appends them to an `eval.render.Mp4Writer` (a temporary file)."""
    import mujoco

    from shoulder_bench.eval import render_model

    model = render_model.build_render_model(width, height, multisample)
    data, poser = mujoco.MjData(model), render_model.Poser(model)
    overlay = writer = tmp = None
    if stage != "frame":
        from shoulder_bench.eval import overlay as overlay_
        from shoulder_bench.eval import render
        from shoulder_bench.tasks import TASKS

        muscles = TASKS["abduction_4m"][0]
        acts = np.random.default_rng(0).uniform(0.0, 0.08, (frames // 3 + 1, len(muscles)))  # a step: 3 frames
        overlay = overlay_.Overlay(width, height, "abduction_4m · ppo (pretrained:ppo_4m)", muscles,
                                 render.colour_scale(float(acts.max())))
        if stage == "mp4":
            tmp = tempfile.TemporaryDirectory()
            writer = render.Mp4Writer(Path(tmp.name) / "speed.mp4", 30)
    try:
        with mujoco.Renderer(model, height=height, width=width) as r:
            angles = np.radians(np.linspace(0.0, 150.0, frames))
            poser.pose(data, angles[0], angles[-1])
            r.update_scene(data, camera="front")
            r.render()  # warm-up: context and textures
            t0 = time.perf_counter()
            for k, a in enumerate(angles):
                poser.pose(data, a, angles[-1] - a)
                r.update_scene(data, camera="front")
                frame = r.render()
                if overlay is not None:
                    frame = overlay.draw(frame, k / 30, float(np.degrees(a)), float(np.degrees(angles[-1] - a)),
                                         acts[k // 3], False)
                if writer is not None:
                    writer.append(frame)
            return frames / (time.perf_counter() - t0)
    finally:
        if writer is not None:
            writer.close()
        if tmp is not None:
            tmp.cleanup()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--height", type=int, default=360)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pipeline", action="store_true",
                    help="the 3-D frame alone, + the overlay, + the overlay and the H.264 encoder (no multisampling)")
    args = ap.parse_args(argv)
    head = (f"{args.width}x{args.height}, {args.frames} frames, best of {args.repeats} (interleaved), "
            f"MUJOCO_GL={os.environ['MUJOCO_GL']}")
    if args.pipeline:
        fps = dict.fromkeys(STAGES, 0.0)
        for _ in range(args.repeats):
            for stage in STAGES:
                fps[stage] = max(fps[stage], frames_per_second(False, args.frames, args.width, args.height, stage))
        print(head + ", no multisampling")
        for stage in STAGES:
            ratio = "" if stage == "frame" else f"  ({fps[stage] / fps['frame']:.2f} x the 3-D frame alone)"
            print(f"{STAGE_LABELS[stage]}: {fps[stage]:.1f} frames/s{ratio}")
        return 0
    best = {False: 0.0, True: 0.0}
    for _ in range(args.repeats):
        for ms in (False, True):
            best[ms] = max(best[ms], frames_per_second(ms, args.frames, args.width, args.height))
    print(head)
    print(f"no multisampling (the default): {best[False]:.1f} frames/s")
    print(f"4x multisampling (--multisample): {best[True]:.1f} frames/s")
    print(f"ratio default / multisampled: {best[False] / best[True]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
