"""shoulder_bench: a MuJoCo shoulder with FEM-derived muscles and a benchmark for learning muscle control.

    import shoulder_bench
    env = shoulder_bench.load("abduction_4m", split="test", seed=0)      # dm_control
    env = gymnasium.make("ShoulderBench/abduction_4m-v0")                # gymnasium
    envs = gymnasium.make_vec("ShoulderBench/abduction_4m-v0", 64)       # gymnasium VectorEnv, batched simulator
"""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless by default; dm_control would try glfw first
from shoulder_bench.model import MODEL_PATH, SCENE_PATH
from shoulder_bench.tasks import list_tasks, load
from shoulder_bench.tasks.gym_env import register_all as _register_gym

__version__ = "0.1.0"
__all__ = ["MODEL_PATH", "SCENE_PATH", "list_tasks", "load", "make_vec"]

_register_gym()


def make_vec(name: str, num_envs: int, device: str = "cpu", seed=None, backend: str = "mujoco", **options):
    """N copies of a task in lockstep as an rsl-rl VecEnv: backend "mujoco" (shoulder_bench.tasks.vec_env, the
    compiled callback) or "mjx" (shoulder_bench.tasks.mjx_env on the JAX device, the 1-DOF tasks; needs the [mjx]
    extra; docs/gpu.md)."""
    from shoulder_bench.tasks import is_3dof

    if backend not in ("mujoco", "mjx"):
        why = " (no MuJoCo Warp backend: float32 cannot carry this model; docs/gpu.md)" if backend == "warp" else ""
        raise ValueError(f"backend must be 'mujoco' or 'mjx', got {backend!r}{why}")
    if backend == "mjx":
        if is_3dof(name):
            raise ValueError(f"{name}: the MJX backend runs the 1-DOF tasks; the 3-DOF tasks run on backend='mujoco'")
        from shoulder_bench.tasks.mjx_env import make

        return make(name, num_envs, device=device, seed=seed, **options)
    if is_3dof(name):  # the full shoulder's tasks (shoulder_bench.tasks.vec_env3)
        from shoulder_bench.tasks.vec_env3 import VecEnv3

        return VecEnv3(name, num_envs, device=device, seed=seed, **options)
    from shoulder_bench.tasks.vec_env import VecEnv

    return VecEnv(name, num_envs, device=device, seed=seed, **options)
