"""How to simulate the v2 (MoBL-ARMS) shoulder: options measured against the reduced-coordinate ground truth.

The model: `shoulder_bench.authoring.mobl` (docs/model_v2.md). Passive motions only (gravity, no muscles, no damping),
the
humerus's own inertia (MoBL, 1.998 kg). Limits are off in the accuracy runs (the free fall swings through 0 deg
elevation; the ground truth has no limits); the stability runs keep each option's limits.

Ground truth: the girdle is linear in elevation, so q(u) = S u (u the free GH coordinates, S the constant coupling
Jacobian from the polycoef slopes) and the reduced dynamics are
    (S^T M(q) S) u'' = S^T (tau - c(q, S u')),
exact for the coupled chain (the Coriolis term S^T c(q, S u') is the 1/2 M_r'(u) u'^2 of the brief in 1 DOF). M and
c (gravity + Coriolis) come from MuJoCo (mj_crb, mj_rne) on the chain with the girdle bodies' 0.1 g placeholder
inertials removed (the humerus only), integrated by RK4 at 1 ms (0.5 ms changes it by < 1e-7 deg).

Motions (2 s, angles compared at the end of every 0.1 s frame):
  locked 1-DOF (plane 0 = coronal, rotation 0): free fall from 90 deg; a constant torque = the gravity torque at
    60 deg from 30 deg at rest (swings 30..102 deg);
  3-DOF: constant torques = the holding torques at (plane 30, elevation 60, rotation 0) from (20, 40, 20) deg at
    rest, with joint springs of 0.5 N m/rad about plane 30 and rotation 0 (a test load: without it plane and
    rotation, which gravity does not restore, spin off); the ground truth has the same springs.
Stability ("protocol"): 200 frames (20 s) at the option's step with limits on: a free fall from 90 deg (3-DOF: from
  plane 30, elevation 90), and seeded random torques, uniform +-2 N m on each free coordinate, held within a frame.
  Stable: finite, no MuJoCo reset, girdle lag < 1 deg, every coordinate within its range +-90 deg.
Cost: one MjData stepped in a loop; `mujoco.rollout` of N = 64 and 1024 copies on 2 threads, 10 frames from 45 deg.

    python benchmarks/v2_dynamics.py            # about 30 s on 2 cores; docs/model_v2.md "Dynamics"
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from shoulder_bench import arm
from shoulder_bench.authoring import mobl

FRAME = 0.1
T_MOTION = 2.0
GT_STEP = 1e-3
PROTOCOL_FRAMES = 200
RANDOM_TORQUE = 2.0  # N m, below the largest gravity torque (3.1 N m at 90 deg)
OVERRUN_DEG = 90.0  # a stable run stays within each free coordinate's range +- this (the limits are soft)
GIRDLE = ("sternoclavicular", "unrotscap", "acromioclavicular", "unrothum")
INTEGRATORS = {"RK4": mujoco.mjtIntegrator.mjINT_RK4, "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}


def free_coordinates(m: mujoco.MjModel) -> list[str]:
    names = [m.joint(i).name for i in range(m.njnt)]
    return [c for c in ("elv_angle", "shoulder_elv", "shoulder_rot") if c in names]


def coupling_jacobian(m: mujoco.MjModel) -> np.ndarray:
    """S (nv x free): d qpos / d u for the linear polycoef couplings (all qpos0 are 0)."""
    free = free_coordinates(m)
    S = np.zeros((m.nv, len(free)))
    for k, c in enumerate(free):
        S[m.joint(c).dofadr[0], k] = 1.0
    for e in range(m.neq):
        if m.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT:
            continue
        c = m.eq_data[e, :5]
        if c[0] != 0 or c[2:].any():
            raise ValueError("the ground truth assumes linear couplings through qpos0 = 0")
        driver = free.index(m.joint(int(m.eq_obj2id[e])).name)
        S[m.jnt_dofadr[m.eq_obj1id[e]], driver] = c[1]
    return S


class Reduced:
    """The reduced-coordinate dynamics of a coupled v2 model (humerus inertia only)."""

    def __init__(self, xml: str, humerus_only: bool = True, spring: tuple | None = None):
        m = mujoco.MjModel.from_xml_string(xml)
        if humerus_only:
            hum = m.body("humerus").id
            for b in range(1, m.nbody):
                if b != hum:
                    m.body_mass[b] = 0.0
                    m.body_inertia[b] = 0.0
        self.m, self.d, self.S = m, mujoco.MjData(m), coupling_jacobian(m)
        self.M, self.c = np.zeros((m.nv, m.nv)), np.zeros(m.nv)
        self.spring = spring  # (stiffness per free coordinate, reference): the 3-DOF test load

    def acc(self, u: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        m, d, S = self.m, self.d, self.S
        d.qpos[:], d.qvel[:] = S @ u, S @ v
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_makeM(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_fullM(m, d, self.M)
        mujoco.mj_rne(m, d, 0, self.c)
        if self.spring is not None:
            tau = tau - self.spring[0] * (u - self.spring[1])
        return np.linalg.solve(S.T @ self.M @ S, tau - S.T @ self.c)

    def holding_torque(self, u) -> np.ndarray:
        """The constant torques that hold pose u (springs relaxed there or absent)."""
        self.acc(np.asarray(u, float), np.zeros(self.S.shape[1]), np.zeros(self.S.shape[1]))
        return self.S.T @ self.c

    def simulate(self, u0, tau, T: float = T_MOTION, h: float = GT_STEP) -> np.ndarray:
        """u at every frame end (frames + 1, free), RK4 with step h."""
        u, v, tau = np.array(u0, float), np.zeros(len(u0)), np.asarray(tau, float)
        every = int(round(FRAME / h))
        out = [u.copy()]
        for i in range(int(round(T / h))):
            k1q, k1v = v, self.acc(u, v, tau)
            k2q, k2v = v + h / 2 * k1v, self.acc(u + h / 2 * k1q, v + h / 2 * k1v, tau)
            k3q, k3v = v + h / 2 * k2v, self.acc(u + h / 2 * k2q, v + h / 2 * k2v, tau)
            k4q, k4v = v + h * k3v, self.acc(u + h * k3q, v + h * k3v, tau)
            u = u + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
            v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            if (i + 1) % every == 0:
                out.append(u.copy())
        return np.array(out)


def fixed_girdle_xml(xml: str) -> str:
    """The reduced 1-DOF hinge: the same model with the girdle joints and their couplings removed, so the humerus
    turns about the resting GH centre (the humerus pose is exact at rest only)."""
    names = "|".join(GIRDLE)
    xml = re.sub(rf'\s*<joint name="({names})_r\d"[^>]*/>', "", xml)
    return re.sub(rf'\s*<joint name="({names})_r\d_con"[^>]*/>', "", xml)


@dataclass
class Option:
    name: str
    xml: str
    integrator: str = "RK4"
    timestep: float = 0.05
    armature: float = 0.0  # on the slaved (girdle, phantom, shoulder1_r2) dofs; not anatomy, no source
    solimp: tuple | None = None  # on the couplings
    harden: bool = False
    plane_armature: float = 0.0  # on elv_angle (3-DOF): not anatomy, no source
    needs: str = ""

    def model(self, limits: bool) -> mujoco.MjModel:
        m = mujoco.MjModel.from_xml_string(self.xml)
        m.opt.timestep, m.opt.integrator = self.timestep, INTEGRATORS[self.integrator]
        if not limits:
            m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
        free = {m.joint(c).dofadr[0] for c in free_coordinates(m)}
        slaved = [k for k in range(m.nv) if k not in free]
        if self.armature:
            m.dof_armature[slaved] = self.armature
        if self.plane_armature:
            m.dof_armature[m.joint("elv_angle").dofadr[0]] = self.plane_armature
        if self.solimp is not None:
            m.eq_solimp[:] = self.solimp
        mujoco.mj_setConst(m, mujoco.MjData(m))  # armature changes dof_invweight0
        if self.harden:
            arm.harden_couplings(m)
        return m


def _bad(d: mujoco.MjData) -> bool:
    return bool(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number) or not np.isfinite(d.qpos).all()


def run_motion(opt: Option, S: np.ndarray, u0, tau, frames: int, limits: bool, torques=None, spring=None):
    """Frame-end free coordinates (frames + 1, free) and the max girdle lag (deg); None if it blew up."""
    m = opt.model(limits)
    if spring is not None:  # MuJoCo joint springs on the free coordinates, as the ground truth's
        for k, c in enumerate(free_coordinates(m)):
            m.jnt_stiffness[m.joint(c).id] = spring[0][k]
            m.qpos_spring[m.joint(c).qposadr[0]] = spring[1][k]
    d = mujoco.MjData(m)
    free = [m.joint(c).dofadr[0] for c in free_coordinates(m)]
    d.qpos[:] = S @ np.asarray(u0)
    spf = int(round(FRAME / m.opt.timestep))
    out, lag = [np.array(u0, float)], 0.0
    for f in range(frames):
        d.qfrc_applied[free] = tau if torques is None else torques[f]
        for _ in range(spf):
            mujoco.mj_step(m, d)
            lag = max(lag, float(np.abs(d.qpos - S @ d.qpos[free]).max()))
        if _bad(d):
            return None, np.inf
        out.append(d.qpos[free].copy())
    return np.array(out), float(np.degrees(lag))


def cost(opt: Option, start_deg: float = 45.0, frames: int = 10, repeats: int = 3) -> dict:
    """steps/s of one MjData; frames/s of that loop and of rollout (N copies, 2 threads)."""
    m = opt.model(limits=True)
    spf = int(round(FRAME / m.opt.timestep))
    d = mujoco.MjData(m)
    free = [m.joint(c).dofadr[0] for c in free_coordinates(m)]
    u = np.radians([start_deg] if len(free) == 1 else [0.0, start_deg, 0.0])
    q0 = coupling_jacobian(m) @ u
    best = np.inf
    n = max(spf * frames, 200)
    for _ in range(repeats):
        d.qpos[:], d.qvel[:] = q0, 0.0
        t = time.perf_counter()
        for _ in range(n):
            mujoco.mj_step(m, d)
        best = min(best, time.perf_counter() - t)
    out = {"steps_s": n / best, "frames_s_single": n / best / spf}
    d.qpos[:], d.qvel[:] = q0, 0.0
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    with rollout.Rollout(nthread=2) as r:
        datas = [mujoco.MjData(m) for _ in range(2)]
        for N in (64, 1024):
            s0 = np.tile(state, (N, 1))
            best = np.inf
            for _ in range(repeats):
                t = time.perf_counter()
                r.rollout([m] * N, datas, s0, nstep=spf * frames, skip_checks=False)
                best = min(best, time.perf_counter() - t)
            out[f"rollout_{N}"] = N * frames / best
    return out


def options() -> list[Option]:
    locked = mobl.model_xml(locked_plane_deg=0.0)
    locked_dyn = mobl.model_xml(locked_plane_deg=0.0, dynamics=True)
    full_dyn = mobl.model_xml(dynamics=True)
    hard = (0.9999, 0.9999, 0.001, 0.5, 2)
    return [
        Option("a0 eq. as built, RK4 50 ms", locked, needs="nothing (the generated MJCF, limits as built)"),
        Option("a1 eq. + armature 1e-3, RK4 50 ms", locked, armature=1e-3, solimp=hard,
               needs="girdle armature 1e-3 kg m^2 (no source), solimp dmax 0.9999"),
        Option("a2 eq. + armature 1e-4, RK4 10 ms", locked, timestep=0.01, armature=1e-4, solimp=hard,
               needs="girdle armature 1e-4 kg m^2 (no source), solimp dmax 0.9999, 10 steps/frame"),
        Option("a3 eq. hardened, implicitfast 1 ms", locked_dyn, integrator="implicitfast", timestep=0.001,
               harden=True, needs="dynamics=True + harden_couplings, 100 steps/frame"),
        Option("a4 eq. hardened, RK4 50 ms", locked_dyn, harden=True,
               needs="dynamics=True + harden_couplings (dof_invweight0 0.01, solimp dmax 0.9999, no source)"),
        Option("b  rest-pivot hinge (girdle fixed), RK4 50 ms", fixed_girdle_xml(locked),
               needs="nothing; the scapula never moves (muscle paths as the fixed girdle)"),
        Option("3-DOF eq. as built, RK4 50 ms", mobl.model_xml(), needs="nothing"),
        Option("3-DOF eq. hardened, RK4 50 ms", full_dyn, harden=True, needs="as a4"),
        Option("3-DOF eq. hardened + plane armature 1e-2, RK4 50 ms", full_dyn, harden=True, plane_armature=1e-2,
               needs="as a4 + elv_angle armature 1e-2 kg m^2 (no source)"),
        Option("3-DOF eq. hardened + plane armature 1e-2, RK4 20 ms", full_dyn, timestep=0.02, harden=True,
               plane_armature=1e-2, needs="as a4 + elv_angle armature 1e-2 kg m^2 (no source), 5 steps/frame"),
    ]


SPRING3 = (np.array([0.5, 0.0, 0.5]), np.radians([30.0, 0.0, 0.0]))  # N m/rad on plane and rotation (test load)


def stable_run(u, lag, m: mujoco.MjModel) -> bool:
    """Finite, no MuJoCo reset, girdle lag below 1 deg, coordinates within their ranges +- OVERRUN_DEG."""
    if u is None or not lag < 1.0:
        return False
    lim = np.array([m.joint(c).range for c in free_coordinates(m)])  # radians in the compiled model
    over = np.radians(OVERRUN_DEG)
    return bool(((u >= lim[:, 0] - over) & (u <= lim[:, 1] + over)).all())


def main() -> None:
    t0 = time.perf_counter()
    mujoco.set_mju_user_warning(lambda msg: None)  # a diverging option is reported in the table
    gt1 = Reduced(mobl.model_xml(locked_plane_deg=0.0))
    gt3 = Reduced(mobl.model_xml(), spring=SPRING3)
    tau60 = gt1.holding_torque(np.radians([60.0]))
    hold3 = gt3.holding_torque(np.radians([30.0, 60.0, 0.0]))
    motions1 = [("free fall from 90", np.radians([90.0]), np.zeros(1)), ("torque, from 30", np.radians([30.0]), tau60)]
    motions3 = [("3-DOF torque + springs", np.radians([20.0, 40.0, 20.0]), hold3)]
    truth = {name: gt.simulate(u0, tau) for gt, ms in ((gt1, motions1), (gt3, motions3)) for name, u0, tau in ms}
    ph = Reduced(mobl.model_xml(locked_plane_deg=0.0), humerus_only=False)
    floor = max(np.degrees(np.abs(ph.simulate(u0, tau) - truth[name])).max() for name, u0, tau in motions1)
    print(f"ground truth: reduced dynamics, RK4 {GT_STEP * 1e3:g} ms. Locked: torque {tau60[0]:.3f} N m (holds 60 deg)."
          f" 3-DOF: torques {np.round(hold3, 3).tolist()} N m hold (30, 60, 0) deg, springs "
          f"{SPRING3[0].tolist()} N m/rad about plane 30, rotation 0 (test load).")
    print(f"The 0.1 g placeholder girdle inertials alone change the locked motions by {floor:.3f} deg.")
    for name, u in truth.items():
        print(f"  {name}: range {np.degrees(u.min(axis=0)).round(1).tolist()} .. "
              f"{np.degrees(u.max(axis=0)).round(1).tolist()} deg")
    rng = np.random.default_rng(0)
    rand1 = rng.uniform(-RANDOM_TORQUE, RANDOM_TORQUE, size=(PROTOCOL_FRAMES, 1))
    rand3 = rng.uniform(-RANDOM_TORQUE, RANDOM_TORQUE, size=(PROTOCOL_FRAMES, 3))
    head = ("| option | max err vs truth, deg (fall / torque) | girdle lag (deg) | "
            "stable 20 s, 0.1 s frames (lag deg) | mj_step steps/s | frames/s: loop | rollout N=64 | "
            "rollout N=1024 | needs |")
    rows = [head, "|" + "---|" * 9]
    for opt in options():
        three = opt.name.startswith("3-DOF")
        motions = motions3 if three else motions1
        m = opt.model(limits=False)
        S = coupling_jacobian(m)
        errs, lag = [], 0.0
        for name, u0, tau in motions:
            u, lg = run_motion(opt, S, u0, tau, int(round(T_MOTION / FRAME)), limits=False,
                               spring=SPRING3 if three else None)
            errs.append(np.inf if u is None else float(np.degrees(np.abs(u - truth[name])).max()))
            lag = max(lag, lg)
        stable, plag = True, 0.0
        u0 = np.radians([30.0, 90.0, 0.0]) if three else np.radians([90.0])
        for torques in (None, rand3 if three else rand1):
            u, lg = run_motion(opt, S, u0, np.zeros(len(u0)), PROTOCOL_FRAMES, limits=True, torques=torques)
            stable &= stable_run(u, lg, m)
            plag = max(plag, lg)
        fixed = m.neq == 0
        c = cost(opt)
        speed = (f"{c['steps_s']:,.0f} | {c['frames_s_single']:,.0f} | {c['rollout_64']:,.0f} | "
                 f"{c['rollout_1024']:,.0f}")
        if not stable:
            speed = " | ".join(f"({x})" for x in speed.split(" | "))
        rows.append(f"| {opt.name} | {' / '.join(_f(e) for e in errs)} | {'fixed at rest' if fixed else _f(lag)} | "
                    f"{'yes' if stable else 'NO'}{'' if fixed else f' ({_f(plag)})'} | {speed} | {opt.needs} |")
        print(rows[-1], flush=True)
    print("\nCosts in parentheses: the option diverges, so they time a blown-up state and mean nothing.\n")
    print("\n".join(rows))
    print(f"\n({time.perf_counter() - t0:.0f} s)")


def _f(x: float) -> str:
    if not np.isfinite(x) or x > 1e4:
        return "diverges"
    return f"{x:.2g}" if x < 0.01 else f"{x:.3f}" if x < 10 else f"{x:.0f}"


if __name__ == "__main__":
    main()
