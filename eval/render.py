"""`shoulder-bench render`: a headless video of one episode (mp4, or GIF for READMEs).

The episode runs in the task's own physics (the locked v2 arm, `shoulder_bench.arm`; 0.1 s frames). A separate
*render model* is built from the task model (`arm.MODEL_FILE`, which carries the scene: sky, floor, lights, cameras)
with `mujoco.MjSpec`: the same bones, girdle couplings and spatial tendons (muscles), no actuators (so the
process-global muscle callback is never involved), plus a translucent ghost humerus on a mocap body that shows the
target elevation. Each video frame interpolates the simulated elevation between frames (a cubic Hermite on angle and
velocity, so the video runs in real time at any frame rate) and poses the whole arm from it, the girdle on its coupling
(`arm.LockedPath.qpos`); it puts the ghost where the humerus is at the target elevation (the humerus's pose from the
same coupled kinematics, girdle included), colours each muscle from pale to saturated red by its activation (ld's
three bundles ld1-ld3 by ld's one activation) and runs kinematics only (`mj_forward`; the render model is never
stepped), so the tendons wrap exactly as in the simulation. Text (time, angle, target, activations) is drawn with
Pillow. The file is written to a temporary name beside `--out` and renamed when complete.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco's GL context

from shoulder_bench.eval.overlay import Overlay  # noqa: E402
from shoulder_bench.eval.render_model import IDLE, PALE, SATURATED, Poser, build_render_model  # noqa: E402

CAMERAS = ("front", "back")
DEFAULT_FPS = {"mp4": 30, "gif": 20}  # GIF frame delays are whole centiseconds: 20 fps = 5 cs, exact real time
MAX_SIZE = 1920


# --- inputs -------------------------------------------------------------------------------------------------------
def _check_out(out: Path | str, gif: bool) -> Path:
    out = Path(out)
    if out.is_dir():  # before the suffix: a folder is not a file name missing its .mp4
        raise ValueError(f"--out {out} is a directory; give a file name such as "
                         f"{out / ('episode.gif' if gif else 'episode.mp4')}")
    if gif and out.suffix.lower() != ".gif":
        out = out.with_suffix(".gif")
    elif not gif and out.suffix.lower() != ".mp4":
        raise ValueError(f"output {out}: an mp4 file must end in .mp4 (or pass --gif for a GIF)")
    if out.is_dir():
        raise ValueError(f"--out {out} is a directory; give a file name such as {out / ('episode' + out.suffix)}")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise FileNotFoundError(f"output directory {parent} does not exist; create it (mkdir -p {parent}) or "
                                f"choose another --out")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"output directory {parent} is not writable; choose another --out")
    return out


def _check_task(name: str) -> str:
    from shoulder_bench.tasks import check_name

    try:
        return check_name(name)
    except KeyError as exc:
        raise ValueError(exc.args[0]) from None


@dataclass
class _Controller:
    label: str
    act: object  # callable(time_step) -> action for env.step
    muscle_model: str | None = None


def _controller(policy: str | None, task: str | None, condition: str | None = None,
                loaded: tuple | None = None) -> tuple[_Controller, str]:
    """The controller for `policy` and the task it runs on (the reference controller plans with `condition`);
    `loaded`: `policy_for(policy)` already called (not loaded again)."""
    import torch

    from shoulder_bench import protocol
    from shoulder_bench.tasks import TASKS

    def flat(obs) -> torch.Tensor:
        x = protocol.flatten(obs)
        return torch.from_numpy(x)[None, :]

    if policy is None:
        from shoulder_bench.controllers import Feedback

        task = _check_task(task or "abduction_4m")
        muscles, discrete, _ = TASKS[task]
        fb = Feedback(muscles)

        def act(ts):
            delta = fb(ts.observation)
            if discrete:  # nearest of the 21 levels
                levels = np.rint((delta + protocol.ACTION_LIMIT) / (2 * protocol.ACTION_LIMIT) * (protocol.LEVELS - 1))
                return np.clip(levels, 0, protocol.LEVELS - 1).astype(np.int64)
            return delta

        return _Controller("feedback (PD)", act), task
    from shoulder_bench.eval.evaluate import policy_for

    module, meta, task = loaded or policy_for(policy, task, options={"condition": condition} if condition else None)
    if policy == "reference":
        label = "reference controller"
    else:
        shown = policy if policy.startswith("pretrained:") else Path(policy).name
        label = f"{meta.get('algo', 'policy')} ({shown})"

    def act(ts):
        with torch.inference_mode():
            a = module(flat(ts.observation))
        return np.asarray(a.detach().cpu().numpy() if hasattr(a, "detach") else a)

    return _Controller(label, act, meta.get("muscle_model")), task


def colour_scale(peak: float) -> float:
    """Activation shown fully saturated: the smallest of 5 %, 10 %, 20 %, 50 %, 100 % at or above the episode's peak
    (activations are often a few percent; a fixed 0..1 scale would leave every muscle pale)."""
    return next((c for c in (0.05, 0.1, 0.2, 0.5) if peak <= c), 1.0)


def _hermite(p0, v0, p1, v1, s, h):
    """Cubic Hermite between (p0, v0) and (p1, v1) over an interval h, at fraction s."""
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * h * v0 + (-2 * s3 + 3 * s2) * p1
            + (s3 - s2) * h * v1)


# --- writers ------------------------------------------------------------------------------------------------------
class Mp4Writer:
    def __init__(self, path: Path, fps: int):
        import imageio

        self.w = imageio.get_writer(str(path), format="FFMPEG", fps=fps, codec="libx264", quality=7,
                                    pixelformat="yuv420p", macro_block_size=2, ffmpeg_log_level="error")

    def append(self, frame):
        self.w.append_data(frame)

    def close(self):
        self.w.close()


class GifWriter:
    """One shared palette (from a sample of the frames plus the muscle colour ramp, no dithering); after the first
    frame, pixels that did not change are written as the transparent index, so each frame costs little more than
    what moved (the usual GIF optimisation; Pillow does not do it by itself)."""

    CLEAR = 255  # palette index of "unchanged"

    def __init__(self, path: Path, fps: int):
        self.path, self.fps, self.frames = path, fps, []

    def append(self, frame):
        self.frames.append(np.ascontiguousarray(frame))

    def close(self):
        from PIL import Image

        if not self.frames:
            return
        w = self.frames[0].shape[1]
        ramp = PALE[:3] + np.linspace(0, 1, w)[:, None] * (SATURATED[:3] - PALE[:3])
        ramp = np.repeat((255 * ramp).astype(np.uint8)[None], 8, axis=0)
        sample = self.frames[:: max(1, len(self.frames) // 8)] + [ramp]
        palette = Image.fromarray(np.concatenate(sample, axis=0)).quantize(colors=self.CLEAR,
                                                                           method=Image.Quantize.MEDIANCUT)
        indexed = [np.asarray(Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE))
                   for f in self.frames]
        images = []
        for k, idx in enumerate(indexed):
            if k:
                idx = np.where(idx == indexed[k - 1], np.uint8(self.CLEAR), idx)
            img = Image.fromarray(idx, mode="P")
            img.putpalette(palette.getpalette())
            images.append(img)
        images[0].save(self.path, format="GIF", save_all=True, append_images=images[1:], transparency=self.CLEAR,
                       disposal=1, duration=int(round(1000 / self.fps)), loop=0, optimize=False)


def write_video(out: Path, fmt: str, fps: int, n_video: int, frame, progress: bool = False) -> float:
    """Write `frame(k)` for k < n_video to `out` (mp4 or gif) through a temporary file beside it, renamed when
    complete (a failure leaves nothing); returns the seconds spent making and appending the frames (the writer's
    final encoding not included)."""
    tmp = out.with_name(f".{out.stem}.tmp{os.getpid()}{out.suffix}")
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_video, desc="render", unit="frame", leave=False)
    spent = 0.0
    try:
        writer = GifWriter(tmp, fps) if fmt == "gif" else Mp4Writer(tmp, fps)
        try:
            for k in range(n_video):
                t0 = time.perf_counter()
                writer.append(frame(k))
                spent += time.perf_counter() - t0
                if bar is not None:
                    bar.update()
        finally:
            writer.close()
        os.replace(tmp, out)
    finally:
        if bar is not None:
            bar.close()
        if tmp.exists():
            tmp.unlink()
    return spent


# --- the episode --------------------------------------------------------------------------------------------------
def render_video(out: Path | str, task: str | None = None, policy: str | None = None, trajectory=None,
                 seconds: float | None = None, width: int = 640, height: int = 480, gif: bool = False,
                 fps: int | None = None, camera: str = "front", seed: int = 0, progress: bool = False,
                 multisample: bool = False, condition: str | None = None) -> dict:
    """Render one episode to `out` (mp4, or GIF with gif=True); returns what was written and how fast.
    multisample: MuJoCo's 4x offscreen multisampling (smoother edges, about half the frame rate on CPU).
    condition: a shoulder condition (`shoulder_bench.conditions`): the episode runs post-op, the video shows its
    geometry (ld_transfer: the rerouted latissimus) and its removed muscles in grey.

    policy: None (PD feedback), "reference", a policy file/run folder or "pretrained:NAME"; trajectory: a CSV path
    (its first trajectory) or a `Trajectory`; default a random test-split target drawn with `seed`.
    """
    import shoulder_bench
    from shoulder_bench import protocol
    from shoulder_bench import trajectory as traj_mod
    from shoulder_bench.tasks import TASKS

    # cheap checks first: nothing is simulated for a bad output, size or camera
    out = _check_out(out, gif)
    fmt = "gif" if gif else "mp4"
    fps = DEFAULT_FPS[fmt] if fps is None else int(fps)
    if not 1 <= fps <= 120:
        raise ValueError(f"fps {fps}: choose 1..120")
    if not (16 <= width <= MAX_SIZE and 16 <= height <= MAX_SIZE):
        raise ValueError(f"size {width}x{height}: width and height must be within 16..{MAX_SIZE} pixels")
    if fmt == "mp4" and (width % 2 or height % 2):
        raise ValueError(f"size {width}x{height}: an mp4 (H.264) needs even width and height")
    if camera not in CAMERAS:
        raise ValueError(f"unknown camera {camera!r}; choose one of {', '.join(CAMERAS)}")
    if seconds is not None and not (np.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds {seconds}: give a positive length in seconds")
    if task is not None:
        task = _check_task(task)
    from shoulder_bench.tasks import is_3dof

    loaded = None
    if task is None and policy not in (None, "reference"):  # a trained policy runs on its own task (loaded once)
        from shoulder_bench.eval.evaluate import policy_for

        loaded = policy_for(policy)
        task = loaded[2]
    if task is not None and is_3dof(task):  # the full shoulder (eval.render3)
        from shoulder_bench.eval.render3 import render_video3

        return render_video3(out, task, policy, trajectory, seconds, width, height, fmt, fps, camera, seed,
                             progress, multisample, loaded, condition)
    from shoulder_bench import conditions

    geometry = conditions.geometry(condition)  # an unknown or clashing condition fails here, before any work
    target = None
    if trajectory is not None:
        if isinstance(trajectory, traj_mod.Trajectory):
            target = trajectory
        else:
            from shoulder_bench.eval.evaluate import CSV_COLUMNS, check_csv

            path = check_csv(trajectory, "--trajectory", f"a CSV file with columns {CSV_COLUMNS}, or leave "
                                                         f"--trajectory out for a random test target")
            target = traj_mod.load_csv(path)[0]

    ctrl, task = _controller(policy, task, condition, loaded)
    muscles = TASKS[task][0]
    removed = {m for m, f in conditions.factors(condition, muscles).items() if f == 0.0}
    options = {} if ctrl.muscle_model is None else {"muscle_model": ctrl.muscle_model}
    options |= {"condition": condition} if condition else {}
    env = shoulder_bench.load(task, split="test", seed=seed, trajectory=target, **options)
    ts = env.reset()
    target = env.task.target
    physics = env.physics
    spec_shape, spec_dtype = env.action_spec().shape, env.action_spec().dtype

    h = protocol.FRAME_S
    duration = target.frames * h
    seconds = duration if seconds is None else min(float(seconds), duration)
    n_video = max(1, int(round(seconds * fps)))

    import mujoco

    from shoulder_bench import arm

    model = build_render_model(width, height, multisample, geometry)
    data = mujoco.MjData(model)
    poser = Poser(model)
    # each muscle's tendons (ld: ld1-ld3) and, per tendon, which of the task's activations colours it; a muscle the
    # condition removed stays grey (IDLE), as one the task does not simulate
    tendons = [(model.tendon(t).id, k) for k, m in enumerate(muscles) if m not in removed for t in arm.ACTUATORS[m]]
    ten_ids, ten_src = [t for t, _ in tendons], [k for _, k in tendons]
    model.tendon_rgba[:] = IDLE

    # simulate first (cheap next to rendering): the colour scale of the activations is then known for the video
    steps = min(target.frames, int(np.ceil(seconds / h - 1e-9)) + 1)
    q, v = [np.radians(physics.angle_deg())], [np.radians(physics.angular_velocity_deg())]  # the elevation
    acts: list[np.ndarray] = []  # activations in force during frame j
    crashed, errors = False, []
    t0 = time.perf_counter()
    for _ in range(steps):
        action = np.asarray(ctrl.act(ts)).reshape(spec_shape)
        if np.issubdtype(spec_dtype, np.integer):
            action = np.rint(action)  # levels from a policy may come as floats
        ts = env.step(action.astype(spec_dtype))
        if physics.failed() or not np.isfinite(physics.data.qpos).all():
            crashed = True
            break
        acts.append(np.clip(physics.activations(muscles), 0.0, 1.0))
        q.append(np.radians(physics.angle_deg()))
        v.append(np.radians(physics.angular_velocity_deg()))
        errors.append(abs(physics.angle_deg() - env.task.target_deg()))
        if ts.last():
            break
    t_sim = time.perf_counter() - t0
    scale = colour_scale(max((float(a.max()) for a in acts), default=0.0))

    title = f"{task} · {condition} · {ctrl.label}" if condition else f"{task} · {ctrl.label}"
    overlay = Overlay(width, height, title, muscles, scale)
    renderer = mujoco.Renderer(model, height=height, width=width)

    def frame(k: int) -> np.ndarray:
        t = k / fps
        j = min(int(t / h + 1e-9), target.frames - 1)
        s = t / h - j
        frozen = len(q) <= j + 1  # past a crash: the arm stays where it last was valid
        if not frozen:
            angle, a = _hermite(q[j], v[j], q[j + 1], v[j + 1], s, h), acts[j]
        else:
            angle, a = q[-1], acts[-1] if acts else np.zeros(len(muscles))
        tgt = _hermite(target.angle_deg[j], target.velocity_deg_s[j], target.angle_deg[j + 1],
                       target.velocity_deg_s[j + 1], s, h)
        poser.pose(data, angle, np.radians(tgt))
        model.tendon_rgba[ten_ids] = PALE + np.minimum(a[ten_src] / scale, 1.0)[:, None] * (SATURATED - PALE)
        renderer.update_scene(data, camera=camera)
        return overlay.draw(renderer.render(), t, float(np.degrees(angle)), float(tgt), a, crashed and frozen)

    wall = time.perf_counter()
    try:
        t_render = write_video(out, fmt, fps, n_video, frame, progress)
    finally:
        renderer.close()
    wall = time.perf_counter() - wall + t_sim
    return {"path": str(out), "frames": n_video, "fps": fps, "seconds": n_video / fps, "width": width,
            "height": height, "task": task, "controller": ctrl.label, "crashed": crashed,
            "mae_deg": float(np.mean(errors)) if errors else float("nan"), "wall_s": wall,
            "render_fps": n_video / max(t_render, 1e-9), "sim_s": t_sim, "render_s": t_render,
            "colour_scale": scale}
