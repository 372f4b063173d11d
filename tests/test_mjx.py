"""The MJX backend (issue 15 §4) against the MuJoCo backend, on the CPU: the force law, the statics and the protocol
pieces against their originals; one frame and one 20 s episode of every task in float64; the float32 drift over 200
frames; DLPack sharing, checkpoints and errors. Skipped without the `[mjx]` extra (jax, mujoco-mjx).

The bounds (docs/gpu.md): float64 agrees with the MuJoCo backend to rounding amplified by the model's conditioning
(the mass matrix of the placeholder girdle bodies is ill-conditioned, so MJX's dense Cholesky and MuJoCo's sparse
factorisation round differently, ~1e-7 relative in single accelerations); the angle stays within FRAME_BOUND_RAD after
one frame and EPISODE_BOUND_RAD over a 20 s episode.
"""
from __future__ import annotations

import os

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("mujoco.mjx")

import jax.numpy as jnp  # noqa: E402
import torch  # noqa: E402

import shoulder_bench  # noqa: E402
from shoulder_bench import arm as arm_  # noqa: E402
from shoulder_bench import mjx_sim, protocol, statics  # noqa: E402
from shoulder_bench import trajectory as targets  # noqa: E402
from shoulder_bench.tasks import TASKS, mjx_env, mjx_protocol  # noqa: E402

FRAME_BOUND_RAD = 1e-6  # measured 4.1e-8 rad (4 copies, one frame; docs/gpu.md)
EPISODE_BOUND_RAD = 1e-4  # measured 1.2e-6 to 5.7e-6 rad over the four tasks' 200 frames (docs/gpu.md)
FLOAT32_BOUND_DEG = 0.5
N = 4  # copies per env
# The frames, the 20 s episodes and the float32 drift compile MJX's forward dynamics (~15 s per env) and take 4.5 min
# together on a 2-core CPU (MJX steps copies one after another there): run them with SHOULDER_BENCH_MJX_LONG=1.
long = pytest.mark.skipif(not os.environ.get("SHOULDER_BENCH_MJX_LONG"),
                          reason="the MJX episode tests take minutes on a CPU; set SHOULDER_BENCH_MJX_LONG=1")


@pytest.fixture(scope="module")
def law():
    return arm_.arm().load_law("fem")


@pytest.fixture(scope="module")
def sim(law):
    return mjx_sim.MjxArm(law, "float64")


def test_the_law_is_the_force_law(law, sim):
    rng = np.random.default_rng(0)
    b = 500
    angle, velocity = rng.uniform(-0.7, 3.9, b), rng.normal(0.0, 4.0, b)  # beyond the grid at both ends too
    act = rng.uniform(-0.2, 1.2, (b, len(law.muscles)))
    act[:20] = law.levels[rng.integers(0, len(law.levels), (20, len(law.muscles)))]  # exactly on the levels
    with mjx_sim.precision("float64"):
        got = np.asarray(mjx_sim.force(sim.jlaw, jnp.asarray(angle), jnp.asarray(velocity),
                                       mjx_sim.per_actuator(sim.jlaw, jnp.asarray(act))))
    np.testing.assert_allclose(got, law.force(angle, velocity, act), rtol=1e-13, atol=1e-11)
    # a one-muscle law drives its actuator only: the others' force is exactly zero
    one = arm_.arm().load_law("fem", ("dmi",))
    jl = mjx_sim.law_arrays(one, law.actuators, "float64")
    with mjx_sim.precision("float64"):
        f = np.asarray(mjx_sim.force(jl, jnp.asarray(angle), jnp.asarray(velocity),
                                     mjx_sim.per_actuator(jl, jnp.asarray(act[:, :1]))))
    col = law.actuators.index("dmi")
    assert (np.delete(f, col, axis=1) == 0.0).all()
    np.testing.assert_allclose(f[:, col], one.force(angle, velocity, act[:, :1])[:, 0], rtol=1e-13, atol=1e-11)


def test_statics_and_poses_match(law, sim):
    deg = np.random.default_rng(1).uniform(20.0, 100.0, 64)
    np.testing.assert_allclose(np.asarray(sim.holding_activation(deg)), statics.holding_activation(law, deg),
                               atol=1e-9)
    np.testing.assert_allclose(np.asarray(sim.qpos(np.radians(deg))), arm_.arm().qpos(np.radians(deg)), atol=1e-14)


def test_tendon_paths_match_mujoco_along_the_elevation(sim):
    """The tendons' lengths on MJX equal MuJoCo's along the coupled path and just off it (the RK4 stages), the middle
    deltoid's inside wrap of its sphere included: with mjx.put_model's own inside-wrap settings its length is off by
    up to 0.32 mm over 110.0-110.6 deg, which made the backends diverge (docs/gpu.md)."""
    import mujoco
    from mujoco import mjx

    deg = np.concatenate([np.arange(-30.0, 210.0, 0.5), np.arange(109.9, 110.7, 0.005)])
    qpos = np.asarray(sim.qpos(np.radians(deg)))
    qpos = np.concatenate([qpos, qpos + np.random.default_rng(4).normal(0.0, 1e-3, qpos.shape)])
    m, d = sim.model, mujoco.MjData(sim.model)
    ref = np.zeros((len(qpos), m.ntendon))
    for k, q in enumerate(qpos):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_tendon(m, d)
        ref[k] = d.ten_length
    with mjx_sim.precision("float64"):
        lengths = jax.jit(jax.vmap(lambda q: mjx.tendon(sim.mx, mjx.kinematics(sim.mx, sim.data.replace(qpos=q)))
                                   .ten_length))(jnp.asarray(qpos))
    np.testing.assert_allclose(np.asarray(lengths), ref, rtol=0, atol=1e-10)


def test_protocol_pieces_match_the_originals():
    rng = np.random.default_rng(2)
    angle, target = rng.uniform(0, 120, 50), rng.uniform(0, 120, 50)
    sent = rng.normal(0.0, 0.02, (50, 4))
    sent[:5] = 3.0  # beyond the reward's cap
    with jax.enable_x64(True):
        for only in (False, True):
            got = mjx_protocol.reward(jnp.asarray(angle), jnp.asarray(target), jnp.asarray(sent), 0.1, 0.009, only)
            np.testing.assert_allclose(np.asarray(got), protocol.reward(angle, target, sent, 0.1, 0.009, only),
                                       rtol=1e-14)
        cols = [rng.normal(size=50) for _ in range(4)] + [rng.uniform(size=(50, 4))]
        ref = protocol.observation(*cols)
        got = mjx_protocol.observation(*map(jnp.asarray, cols))
        np.testing.assert_array_equal(np.asarray(got), np.concatenate([ref[k] for k in protocol.OBSERVATION_KEYS], 1))
        levels = np.arange(protocol.LEVELS)[:, None].repeat(2, axis=1)
        np.testing.assert_allclose(np.asarray(mjx_protocol.to_delta(jnp.asarray(levels, jnp.float64), True)[0]),
                                   protocol.to_delta(levels, 2, True, batch=protocol.LEVELS)[0], rtol=1e-14)
        for split in targets.SPLITS:  # the same end points give trajectory.random_trajectory's samples
            spec = targets.SPLITS[split]
            n_seg = int(round(spec["duration_s"] / targets.SEGMENT_S))
            points = np.random.default_rng(3).uniform(*spec["range_deg"], size=n_seg + 1)
            ref = targets.random_trajectory(np.random.default_rng(3), split)
            a, v = mjx_protocol.quintic_targets(jnp.asarray(points[None]))
            np.testing.assert_allclose(np.asarray(a)[0], ref.angle_deg, rtol=1e-15, atol=1e-12)
            np.testing.assert_allclose(np.asarray(v)[0], ref.velocity_deg_s, rtol=1e-12, atol=1e-10)


def pair(task: str, trajectories, **options):
    """The MJX env (float64) and the MuJoCo backend's env on the same targets."""
    mjx = mjx_env.make(task, len(trajectories), seed=0, trajectory=list(trajectories), **options)
    ref = shoulder_bench.make_vec(task, len(trajectories), seed=0, trajectory=list(trajectories), **options)
    return mjx, ref


def actions(task: str, frames: int, seed: int = 0) -> np.ndarray:
    n, discrete = len(TASKS[task][0]), TASKS[task][1]
    rng = np.random.default_rng(seed)
    if discrete:
        return rng.integers(0, protocol.LEVELS, (frames, N, n))
    return rng.uniform(-protocol.ACTION_LIMIT, protocol.ACTION_LIMIT, (frames, N, n))


def run_both(task: str, frames: int, **options):
    """Angles (frames, N) deg of both backends under the same actions, and the rewards."""
    test = targets.load_test_set()[:N]
    mjx, ref = pair(task, test, **options)
    np.testing.assert_allclose(mjx.get_observations()["policy"].numpy(), ref.get_observations()["policy"].numpy(),
                               rtol=1e-6, atol=1e-5)
    out = {"mjx": [], "ref": [], "r_mjx": [], "r_ref": []}
    for a in actions(task, frames):
        for key, env in (("mjx", mjx), ("ref", ref)):
            _, r, done, _ = env.step(torch.as_tensor(a))
            out[key].append(np.array(env.last_angle_deg))
            out[f"r_{key}"].append(np.array(env.last_reward))
    ref.close()
    return {k: np.array(v) for k, v in out.items()}, mjx, ref


@long
@pytest.mark.parametrize("task", list(TASKS))
def test_one_frame_of_every_task_matches_the_mujoco_backend(task):
    out, _, _ = run_both(task, 1)
    assert np.abs(np.radians(out["mjx"] - out["ref"])).max() <= FRAME_BOUND_RAD
    np.testing.assert_allclose(out["r_mjx"], out["r_ref"], rtol=0, atol=1e-6)


@long
@pytest.mark.parametrize("task", list(TASKS))
def test_a_20_s_episode_of_every_task_matches_the_mujoco_backend(task):
    frames = targets.load_test_set()[0].frames
    out, mjx, _ = run_both(task, frames)
    err = np.abs(np.radians(out["mjx"] - out["ref"])).max()
    print(f"{task}: max |angle difference| over {frames} frames {err:.2e} rad")
    assert err <= EPISODE_BOUND_RAD
    np.testing.assert_allclose(out["r_mjx"], out["r_ref"], rtol=0, atol=1e-3)
    assert int(mjx.episode_length_buf.max()) == 0  # every copy's episode ended with its target and restarted


@long
@pytest.mark.xfail(strict=True, reason="float32 cannot carry this model's dynamics: its mass matrix's condition "
                   "number (2.7e8) exceeds float32's 1/eps; the first frame's accelerations are 0 or NaN (docs/gpu.md)")
def test_float32_drift_over_200_frames_is_bounded():
    """float32 against float64 on the same actions: the drift of the angle over 200 frames (docs/gpu.md)."""
    task, test = "abduction_4m", targets.load_test_set()[:N]
    envs = {d: mjx_env.make(task, N, seed=0, trajectory=list(test), dtype=d) for d in ("float32", "float64")}
    drift = []
    for a in actions(task, 200, seed=5):
        angles = {}
        for d, env in envs.items():
            env.step(torch.as_tensor(a, dtype=torch.float32))
            angles[d] = env.last_angle_deg.astype(np.float64)
        drift.append(np.abs(angles["float32"] - angles["float64"]).max())
    print(f"float32 drift over 200 frames: max {max(drift):.2e} deg, after 1 frame {drift[0]:.2e}, "
          f"after 100 {drift[99]:.2e}")
    assert max(drift) <= FLOAT32_BOUND_DEG


@pytest.mark.slow
def test_dlpack_shares_memory_and_bad_actions_raise():
    venv = mjx_env.make("abduction_ssp", N, seed=0)
    obs = venv.get_observations()["policy"]
    assert obs.shape == (N, 5) and obs.dtype == torch.float32
    flat = jnp.zeros((2, 3), jnp.float32)
    assert mjx_env.to_torch(flat).data_ptr() == flat.unsafe_buffer_pointer()  # zero-copy
    before = venv.qpos.copy()
    for bad in (torch.zeros(N, 2), torch.full((N, 1), float("nan"))):
        with pytest.raises(ValueError, match="action"):
            venv.step(bad)
    np.testing.assert_array_equal(venv.qpos, before)  # nothing changed
    with pytest.raises(ValueError, match="dtype"):
        mjx_env.make("abduction_ssp", 1, dtype="float16")
    with pytest.raises(ValueError, match="device"):
        mjx_env.make("abduction_ssp", 1, device="meta")
