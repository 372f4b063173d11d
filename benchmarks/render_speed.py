"""Render frame rate with and without multisampling, side by side in one run (issue: >= 70 frames/s at 480 x 360).

    MUJOCO_GL=egl .venv/bin/python benchmarks/render_speed.py [--frames 200] [--width 480] [--height 360] [--repeats 3]

Renders the same poses (the arm sweeping 0-150 deg, the ghost opposite) with `eval.render_model`'s model and MuJoCo's
`Renderer`, alternating the two settings `--repeats` times, and prints the best frames/s of each and their ratio.
The overlay and the video encoder (`shoulder-bench render` adds them) are not included: this is the 3-D frame only.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")


def frames_per_second(multisample: bool, frames: int, width: int, height: int) -> float:
    import mujoco

    from shoulder_bench.eval import render_model

    model = render_model.build_render_model(width, height, multisample)
    data, poser = mujoco.MjData(model), render_model.Poser(model)
    with mujoco.Renderer(model, height=height, width=width) as r:
        angles = np.radians(np.linspace(0.0, 150.0, frames))
        poser.pose(data, angles[0], angles[-1])
        r.update_scene(data, camera="front")
        r.render()  # warm-up: context and textures
        t0 = time.perf_counter()
        for a in angles:
            poser.pose(data, a, angles[-1] - a)
            r.update_scene(data, camera="front")
            r.render()
        return frames / (time.perf_counter() - t0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--height", type=int, default=360)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    best = {False: 0.0, True: 0.0}
    for _ in range(args.repeats):
        for ms in (False, True):
            best[ms] = max(best[ms], frames_per_second(ms, args.frames, args.width, args.height))
    print(f"{args.width}x{args.height}, {args.frames} frames, best of {args.repeats} (interleaved), "
          f"MUJOCO_GL={os.environ['MUJOCO_GL']}")
    print(f"no multisampling (the default): {best[False]:.1f} frames/s")
    print(f"4x multisampling (--multisample): {best[True]:.1f} frames/s")
    print(f"ratio default / multisampled: {best[False] / best[True]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
