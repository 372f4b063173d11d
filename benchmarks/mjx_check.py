"""What MJX makes of our model, on the CPU (no GPU here): run it in a separate venv with mujoco-mjx installed,

    python3 -m venv /tmp/mjx-venv && /tmp/mjx-venv/bin/pip install mujoco-mjx==3.17.0
    /tmp/mjx-venv/bin/python benchmarks/mjx_check.py

It reports whether `mjx.put_model` accepts the `user` actuators (it does not), whether it accepts the model with
fixed-gain actuators (tendon wrapping, RK4, limits), how one `mjx.forward` compares with C MuJoCo, and batched
`vmap(mjx.forward)` throughput on the CPU backend (not a GPU figure). See docs/scaling.md.
"""
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

jax.config.update("jax_enable_x64", True)
MODEL = Path(__file__).resolve().parents[1] / "models" / "shoulder.xml"


def main() -> None:
    print("mujoco", mujoco.__version__, "jax", jax.__version__, jax.devices())
    m = mujoco.MjModel.from_xml_path(str(MODEL))
    try:
        mjx.put_model(m)
        print("put_model with user gain: accepted")
    except Exception as e:  # noqa: BLE001 (report whatever MJX says)
        print("put_model with user gain:", type(e).__name__, e)
    m.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    m.actuator_gainprm[:] = 0
    m.actuator_gainprm[:, 0] = 1
    m.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
    m.actuator_ctrllimited[:] = 0
    mx = mjx.put_model(m)
    print("put_model with fixed gain: ok")
    rng = np.random.default_rng(0)
    d = mujoco.MjData(m)
    fwd = jax.jit(mjx.forward)
    errs = []
    for _ in range(20):
        q, v, u = rng.uniform(-0.3, 2.9), rng.uniform(-5, 5), -rng.uniform(0, 300, m.nu)
        d.qpos[0], d.qvel[0], d.ctrl[:] = q, v, u
        mujoco.mj_forward(m, d)
        dx = fwd(mx, mjx.make_data(mx).replace(qpos=jnp.array([q]), qvel=jnp.array([v]), ctrl=jnp.array(u)))
        errs.append(abs(float(dx.qacc[0]) - d.qacc[0]) / max(1.0, abs(d.qacc[0])))
    print(f"forward vs C MuJoCo: max relative qacc error {max(errs):.2e}")
    for n in (1024, 4096):
        bf = jax.jit(jax.vmap(mjx.forward, in_axes=(None, 0)))
        base = mjx.make_data(mx)
        batch = jax.tree_util.tree_map(lambda x, n=n: jnp.broadcast_to(x, (n,) + x.shape) if hasattr(x, "shape")
                                       else x, base)
        batch = batch.replace(qpos=jnp.array(rng.uniform(0, 2.5, (n, 1))),
                              ctrl=jnp.array(-rng.uniform(0, 300, (n, m.nu))))
        bf(mx, batch).qacc.block_until_ready()
        best = 1e9
        for _ in range(3):
            t = time.perf_counter()
            bf(mx, batch).qacc.block_until_ready()
            best = min(best, time.perf_counter() - t)
        print(f"vmap(mjx.forward) CPU N={n}: {n / best:,.0f} forward/s -> {n / best / 8:,.0f} frames/s "
              f"(8 forwards per frame)")


if __name__ == "__main__":
    main()
