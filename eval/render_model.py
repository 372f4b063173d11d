"""The render model of `shoulder-bench render` (`eval.render`): the task model (`arm.MODEL_FILE`, scene included)
without actuators, so the process-global muscle callback is never involved, plus a translucent ghost humerus on a
mocap body at the target elevation; `Poser` poses both from the arm's coupled kinematics; the muscle colours."""
from __future__ import annotations

import numpy as np

PALE = np.array([0.93, 0.80, 0.78, 0.85])  # muscle at activation 0
SATURATED = np.array([0.90, 0.02, 0.02, 1.0])  # muscle at activation 1
IDLE = np.array([0.60, 0.60, 0.60, 0.35])  # a muscle the task does not simulate
GHOST_RGBA = (0.55, 0.85, 1.0, 0.22)
GHOST_SCALE = 1.03  # slightly larger than the bone: no z-fighting where ghost and arm coincide
GHOST = "ghost"  # the ghost's mocap body


MULTISAMPLES = 4  # `multisample=True`: MuJoCo's default offscreen multisampling (smoother edges, about half the speed)
TESSELLATION = (16, 8)  # slices, stacks of the built-in shapes (MuJoCo's default 28, 16)


def build_render_model(width: int, height: int, multisample: bool = False, geometry: str | None = None,
                       path=None):
    """The task model of `geometry` (`arm.model_file`: None the intact `arm.MODEL_FILE`, "ld_transfer" the rerouted
    latissimus; scene included) without actuators, plus a translucent ghost humerus: a mocap
    body `GHOST` with a copy of the humerus's geoms, `GHOST_SCALE` larger (`Poser` places it). No offscreen
    multisampling unless `multisample` (MULTISAMPLES samples): software rendering pays for every sample."""
    import mujoco

    from shoulder_bench import arm

    spec = mujoco.MjSpec.from_file(str(path or arm.model_file(geometry)))  # path: another task model (3-DOF)
    for act in list(spec.actuators):  # visual only: no user actuators, so the muscle callback never runs
        spec.delete(act)
    spec.visual.global_.offwidth = max(width, spec.visual.global_.offwidth)
    spec.visual.global_.offheight = max(height, spec.visual.global_.offheight)
    spec.visual.quality.offsamples = MULTISAMPLES if multisample else 0
    # software rendering draws every triangle on the CPU: the tendons are drawn as capsules, one per segment, and at
    # MuJoCo's default tessellation (28 slices, 16 stacks) they take ~40 % of a 480 x 360 frame; at 16 x 8 the frame
    # is ~1.7x faster (benchmarks/render_speed.py) and the capsules still look round at these sizes
    spec.visual.quality.numslices, spec.visual.quality.numstacks = TESSELLATION
    bare = spec.compile()  # the humerus's geoms as compiled (a fromto capsule becomes pos, quat, size)
    hum = bare.body("humerus").id
    ghost = spec.worldbody.add_body(name=GHOST, mocap=True)
    for g in np.flatnonzero((bare.geom_bodyid == hum) & (bare.geom_group == 1)):  # the bone, not the wrap geoms
        size = bare.geom_size[g].copy()
        if bare.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            raise ValueError("render: a mesh humerus needs a scaled copy of its mesh for the ghost")
        ghost.add_geom(name=f"ghost_{bare.geom(g).name}", type=bare.geom_type[g], size=GHOST_SCALE * size,
                       pos=bare.geom_pos[g], quat=bare.geom_quat[g], rgba=GHOST_RGBA, contype=0, conaffinity=0,
                       group=1)
    model = spec.compile()
    model.tendon_width[:] = np.maximum(model.tendon_width, 0.006)  # visible at README sizes
    # software rendering (EGL on CPU): shadow maps cost ~4x the frame and the floor is far below the view anyway
    model.light_castshadow[:] = 0
    model.mat_reflectance[:] = 0
    return model


class Poser:
    """Poses the render model: the arm at an elevation (the girdle on its coupling), the ghost at another."""

    def __init__(self, model):
        from shoulder_bench import arm

        self.model, self.path = model, arm.LockedPath(model=model)  # the render model's own coupled kinematics
        self.hum = model.body("humerus").id
        self.mocap = int(model.body_mocapid[model.body(GHOST).id])

    def pose(self, data, elevation_rad: float, target_rad: float) -> None:
        """Set `data` (the render model's) to the arm at `elevation_rad` and the ghost at `target_rad`; then
        mj_forward."""
        import mujoco

        g = self.path.pose(target_rad)  # the humerus where it is at the target elevation (girdle included)
        data.mocap_pos[self.mocap] = g.xpos[self.hum]
        data.mocap_quat[self.mocap] = g.xquat[self.hum]
        data.qpos[:] = self.path.qpos(elevation_rad)[0]
        mujoco.mj_forward(self.model, data)
