"""`shoulder-bench render --task track_3dof ...`: a headless video of one 3-DOF episode (the full shoulder).

As `eval.render` for the 1-DOF tasks: the episode runs in the task's physics first; a render model (the task model
`full_arm.model_file(geometry)`: the condition's, ld_transfer's rerouted latissimus included; scene included, without
actuators, plus the translucent ghost humerus of
`render_model.build_render_model`) is then posed at every video frame from the simulated positions (linear between
0.1 s frames: the scapula and clavicle move with the arm by the rhythm), the ghost where the humerus is at the
target's coordinates, each muscle coloured by its activation (ld's three bundles by ld's one); kinematics only.
The overlay shows the elevation and its target, and the activations.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from shoulder_bench.eval.overlay import Overlay
from shoulder_bench.eval.render import colour_scale, write_video
from shoulder_bench.eval.render_model import GHOST, IDLE, PALE, SATURATED, build_render_model


def render_video3(out: Path, task: str, policy: str | None, trajectory=None, seconds: float | None = None,
                  width: int = 640, height: int = 480, fmt: str = "mp4", fps: int = 30, camera: str = "front",
                  seed: int = 0, progress: bool = False, multisample: bool = False,
                  loaded: tuple | None = None, condition: str | None = None) -> dict:
    """Render one episode of the 3-DOF `task` to `out` (inputs already checked by `eval.render.render_video`).
    policy: None or "reference" (the 3-DOF reference controller), a policy file/run folder or pretrained:NAME;
    trajectory: an ADL name, a 3-DOF CSV or a `Trajectory3`; default a random test target drawn with `seed`;
    loaded: `policy_for(policy)` already called by the caller (not loaded again); condition: the episode runs post-op
    (`shoulder_bench.conditions`; the reference controller plans with it), the video shows its geometry (ld_transfer:
    the rerouted latissimus) and a removed muscle grey."""
    import mujoco
    import torch

    import shoulder_bench
    from shoulder_bench import conditions, full_arm, protocol, trajectory3

    post_op = {} if condition is None else {"condition": condition}
    if policy in (None, "reference"):
        from shoulder_bench.eval.reference3 import ReferenceController3

        ctrl, label = ReferenceController3(task, **post_op), "reference controller"
    else:
        from shoulder_bench.eval.evaluate import policy_for

        ctrl, meta, task = loaded or policy_for(policy, task)
        label = f"{str(meta.get('algo', 'policy')).upper()} ({policy})"
    if isinstance(trajectory, Path) and str(trajectory) in trajectory3.ADL:  # the CLI passes a Path
        trajectory = str(trajectory)
    env = shoulder_bench.load(task, split="test", seed=seed, trajectory=trajectory3.as_trajectory(trajectory),
                              **post_op)
    ts = env.reset()
    physics, target, muscles = env.physics, env.task.target, env.task.muscles
    spec = env.action_spec()
    qpos, acts, errors, crashed = [physics.data.qpos.copy()], [], [], False
    duration = target.frames * protocol.FRAME_S
    seconds = duration if seconds is None else min(float(seconds), duration)
    steps = min(target.frames, int(np.ceil(seconds / protocol.FRAME_S - 1e-9)) + 1)
    t0 = time.perf_counter()
    with torch.inference_mode():
        for _ in range(steps):
            obs = torch.as_tensor(protocol.flatten(ts.observation))[None]
            action = np.asarray(ctrl(obs)).reshape(spec.shape)
            ts = env.step(np.rint(action).astype(spec.dtype) if np.issubdtype(spec.dtype, np.integer) else action)
            if physics.failed():
                crashed = True
                break
            qpos.append(physics.data.qpos.copy())
            acts.append(np.clip(physics.activations(muscles), 0.0, 1.0))
            errors.append(env.task.error_deg(physics))
            if ts.last():
                break
    t_sim = time.perf_counter() - t0
    scale = colour_scale(max((float(a.max()) for a in acts), default=0.0))
    model = build_render_model(width, height, multisample, path=full_arm.model_file(env.task.geometry))
    data, ghost_data = mujoco.MjData(model), mujoco.MjData(model)
    pose = full_arm.Pose(model)
    hum, mocap = model.body("humerus").id, int(model.body_mocapid[model.body(GHOST).id])
    removed = {m for m, f in conditions.factors(condition, muscles).items() if f == 0.0}  # drawn grey (IDLE)
    tendons = [(model.tendon(t).id, k) for k, m in enumerate(muscles) if m not in removed
               for t in full_arm.ACTUATORS[m]]
    ten_ids, ten_src = [t for t, _ in tendons], [k for _, k in tendons]
    model.tendon_rgba[:] = IDLE
    title = f"{task} · {condition} · {label}" if condition else f"{task} · {label}"
    overlay = Overlay(width, height, title, muscles, scale)
    n_video = max(1, int(round(seconds * fps)))
    renderer = mujoco.Renderer(model, height=height, width=width)

    def frame(k: int) -> np.ndarray:
        t = k / fps
        j = min(int(t / protocol.FRAME_S + 1e-9), target.frames - 1)
        s = t / protocol.FRAME_S - j
        frozen = len(qpos) <= j + 1
        q = qpos[-1] if frozen else (1 - s) * qpos[j] + s * qpos[j + 1]
        a = (acts[-1] if acts else np.zeros(len(muscles))) if frozen else acts[j]
        goal = (1 - s) * target.angle_deg[j] + s * target.angle_deg[j + 1]
        ghost_data.qpos[:] = pose.qpos(goal)[0]
        mujoco.mj_kinematics(model, ghost_data)
        data.mocap_pos[mocap], data.mocap_quat[mocap] = ghost_data.xpos[hum], ghost_data.xquat[hum]
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        model.tendon_rgba[ten_ids] = PALE + np.minimum(a[ten_src] / scale, 1.0)[:, None] * (SATURATED - PALE)
        renderer.update_scene(data, camera=camera)
        elevation = float(np.degrees(q[pose.qadr[1]]))
        return overlay.draw(renderer.render(), t, elevation, float(goal[1]), a, crashed and frozen)

    try:
        t_render = write_video(out, fmt, fps, n_video, frame, progress)
    finally:
        renderer.close()
    return {"path": str(out), "frames": n_video, "fps": fps, "seconds": n_video / fps, "width": width,
            "height": height, "task": task, "controller": label, "crashed": crashed,
            "mae_deg": float(np.mean(errors)) if errors else float("nan"), "wall_s": t_sim + t_render,
            "render_fps": n_video / max(t_render, 1e-9), "sim_s": t_sim, "render_s": t_render, "colour_scale": scale}
