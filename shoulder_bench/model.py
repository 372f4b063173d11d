"""Loading the shoulder model and the process-global muscle callback.

MuJoCo's `mjcb_act_gain` / `mjcb_act_bias` are process-global. Two facts shape this module:
- While a Python callback is installed, *compiling* a model with `user` actuators fails ("Python exception raised":
  the bindings cannot wrap the half-built model). `compile_model` therefore compiles the actuators as plain fixed-gain
  ones and makes them `user` actuators afterwards (the compiled model is the same, array for array): nothing global
  changes, so models can be built in several threads at once, also while other threads step theirs.
- Several models (and copies of them) may live in one process. Each model carries its force law's id in
  `actuator_user[:, 0]` (column 1 is the muscle's column in that law), so the one installed callback finds the law of
  whatever model it is called for; an unknown id gives zero force rather than an exception inside MuJoCo. The law
  sees one joint's angle and velocity, chosen per `attach_law` (v1: abduction, v2: shoulder_elv) and kept with the id;
  a length-keyed law (the full shoulder's `tendon_law.TendonLaw`) sees each actuator's tendon length instead.

A law with band corrections (`band_lines`, the full shoulder's line_of_action="band") adds a third callback,
`mjcb_passive`, always the compiled one (`native.passive`): a Python passive callback would make every compile fail.

Per evaluation MuJoCo calls gain then bias for actuator 0, 1, ... in order; the gain call of the first muscle
evaluates the law for all muscles at once (one compiled kernel call) and the other calls read that result. The
callbacks run 8 times per actuator and frame (4 RK4 stages x 2 physics steps), so they keep per-model and per-data
state keyed by `id()` (checked against a weak reference) instead of slower attribute look-ups.
"""
from __future__ import annotations

import itertools
import warnings
import weakref
from pathlib import Path

import mujoco
import numpy as np

# re-exported: model.compile_model, model.MODELS_DIR, ... are where callers have always found them
from shoulder_bench.geometry import JOINT, compile_model, moment_arms, tendon_geometry, tendon_jacobian  # noqa: F401
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.paths import MODEL_PATH, MODELS_DIR, SCENE_PATH  # noqa: F401

DEFAULT_MUSCLE_MODEL = "fem"  # tables from the thin-shell FEM (docs/fem.md); "hill" is the alternative

_LAWS: dict[int, tuple] = {}  # law id -> (ForceLaw, name of the joint it sees), one id per attach_law
_law_ids = itertools.count(1)
_models: dict[int, _ModelEntry] = {}  # id(MjModel) -> what the callback needs for that model
_datas: dict[int, _DataEntry] = {}  # id(MjData) -> views and the forces of the current evaluation


DEFAULT_JOINTS = (JOINT, "shoulder_elv")  # the law's angle coordinate, first present: v1's abduction, v2's elevation


def law_joint(m: mujoco.MjModel, joint: str | None = None) -> str:
    """The joint whose angle and velocity a force law sees in model `m`: `joint`, or the first of DEFAULT_JOINTS the
    model has; ValueError naming the model's joints otherwise."""
    joints = [m.joint(j).name for j in range(m.njnt)]
    if joint is None:
        joint = next((j for j in DEFAULT_JOINTS if j in joints), None)
        if joint is None:
            raise ValueError(f"the model has none of the law joints {DEFAULT_JOINTS}; name one (joint=...) of "
                             f"its joints {joints}")
    elif joint not in joints:
        raise ValueError(f"the model has no joint {joint!r}; its joints are {joints}")
    return joint


class _ModelEntry:
    """Per model: its law, the law column of each actuator (-1: not simulated), actuator order, joint addresses."""

    __slots__ = ("ref", "law", "cols", "order", "first", "qadr", "vadr", "acts", "band")

    def __init__(self, m: mujoco.MjModel, law, joint: str | None):
        self.ref = weakref.ref(m)
        self.law = law
        self.cols = [int(c) for c in np.asarray(m.actuator_user)[:, 1]]
        # the actuator whose ctrl holds each muscle's activation (a muscle's actuators all carry it: v2's ld1-3)
        self.order = np.array([self.cols.index(c) for c in law.first_table])
        self.first = min(i for i, c in enumerate(self.cols) if c >= 0)
        self.acts = np.array([self.cols.index(c) for c in range(len(law.actuators))])  # actuator of each column
        if joint is None:  # a length-keyed law (TendonLaw) reads each actuator's length, no joint
            self.qadr = self.vadr = -1
        else:
            jnt = m.joint(joint).id
            self.qadr, self.vadr = int(m.jnt_qposadr[jnt]), int(m.jnt_dofadr[jnt])
        self.band = None  # a law with band lines: (its band tendons' columns, the coordinates' qpos, dof addresses)
        if getattr(law, "lines", None) is not None:
            from shoulder_bench.full_arm import COORDINATES

            self.band = (np.array([law.actuators.index(t) for t in law.lines.tendons]),
                         np.array([int(m.joint(c).qposadr[0]) for c in COORDINATES]),
                         np.array([int(m.joint(c).dofadr[0]) for c in COORDINATES]))


class _DataEntry:
    __slots__ = ("ref", "qpos", "qvel", "ctrl", "length", "speed", "gain", "bias")

    def __init__(self, d: mujoco.MjData):
        self.ref = weakref.ref(d)
        self.qpos, self.qvel, self.ctrl = d.qpos, d.qvel, d.ctrl  # views stay valid while d lives
        self.length, self.speed = d.actuator_length, d.actuator_velocity
        self.gain, self.bias = [], []


def _model_entry(m: mujoco.MjModel) -> _ModelEntry | None:
    e = _models.get(id(m))
    if e is not None and e.ref() is m:
        return e
    user = np.asarray(m.actuator_user)
    attached = _LAWS.get(int(user[0, 0])) if m.nu and user.size else None
    if attached is None:
        return None
    e = _models[id(m)] = _ModelEntry(m, *attached)
    return e


def _data_entry(d: mujoco.MjData) -> _DataEntry:
    e = _datas.get(id(d))
    if e is None or e.ref() is not d:
        e = _datas[id(d)] = _DataEntry(d)
    return e


# the last (model, data, model entry, data entry), the common case; one tuple, replaced whole, so that a thread never
# reads another thread's half-written entry
_current: list = [(None, None, None, None)]


def _entries(m, d):
    cur = _current[0]
    if m is cur[0] and d is cur[1]:
        return cur[2], cur[3]
    e = _model_entry(m)
    s = None if e is None else _data_entry(d)
    _current[0] = (m, d, e, s)
    return e, s


def _gain(m, d, i):
    e, s = _entries(m, d)
    if e is None:
        return 0.0
    c = e.cols[i]
    if c < 0:
        return 0.0
    if i == e.first:  # MuJoCo visits actuators in order: evaluate all muscles once, at the first one
        if e.qadr < 0:  # a length-keyed law: each tendon's length and lengthening rate (MuJoCo's actuator ones are
            gear = np.asarray(m.actuator_gear)[e.acts, 0]  # gear x the tendon's; gear: 1, or a strength draw)
            gear = np.where(gear != 0.0, gear, 1.0)
            length, speed = s.length[e.acts] / gear, s.speed[e.acts] / gear
            departures = None
            if e.band is not None:  # the band tendons: their band's length and lengthening rate (band_lines)
                cols, qadr, dadr = e.band
                a = s.ctrl[e.order][e.law.muscle_of[cols]]
                dl, dv = e.law.lines.lengthening(np.degrees(s.qpos[qadr]), s.qvel[dadr], a)
                length[cols] += dl[0]
                speed[cols] += dv[0]
                departures = e.law.departures(np.degrees(s.qpos[qadr]))  # "band_fibres": (1, nt, n), else None
            gain, bias = e.law.gain_bias_one(length, speed, s.ctrl[e.order],
                                             None if departures is None else departures[0])
        else:
            gain, bias = e.law.gain_bias_one(s.qpos[e.qadr], s.qvel[e.vadr], s.ctrl[e.order])
        s.gain = [-x for x in gain.tolist()]  # negative: muscles pull, shortening their tendon
        s.bias = [-x for x in bias.tolist()]
    return s.gain[c]


def _bias(m, d, i):
    e, s = _entries(m, d)
    if e is None:
        return 0.0
    c = e.cols[i]
    return 0.0 if c < 0 else s.bias[c]


_installed: list = [None]  # "native" or "python": what install_callbacks installed last


def install_callbacks(native: bool | None = None) -> None:
    """Install the muscle callbacks (idempotent). native=None (default): the compiled ones (`shoulder_bench.native`:
    GIL-free, so `mujoco.rollout`'s threads can use them) where available, else the Python ones with a warning saying
    why; True: compiled or RuntimeError; False: the Python ones (`_gain` / `_bias`, the reference of the equivalence
    tests). Both evaluate the same law for the same model: `attach_law` registers every law with both."""
    from shoulder_bench import native as compiled  # lazily: numba loads (or compiles) the callbacks

    use = compiled.AVAILABLE if native is None else bool(native)
    if native is None and not use and _installed[0] != "python":
        warnings.warn(f"{compiled.REASON}; using the Python muscle callbacks", RuntimeWarning, stacklevel=2)
    if use and not compiled.AVAILABLE:
        raise RuntimeError(compiled.REASON)
    gain, bias = (compiled.GAIN, compiled.BIAS) if use else (_gain, _bias)
    if mujoco.get_mjcb_act_gain() is not gain:
        mujoco.set_mjcb_act_gain(gain)
    if mujoco.get_mjcb_act_bias() is not bias:
        mujoco.set_mjcb_act_bias(bias)
    # the band corrections' passive forces: compiled whichever actuator callbacks (a Python passive callback would,
    # like the Python actuator callbacks, make every compile fail; it has no way round that, so there is none)
    if compiled.AVAILABLE and mujoco.get_mjcb_passive() is not compiled.PASSIVE:
        mujoco.set_mjcb_passive(compiled.PASSIVE)
    _installed[0] = "native" if use else "python"


def installed_callbacks() -> str | None:
    """"native", "python" or None: which muscle callbacks `install_callbacks` installed last."""
    return _installed[0]


def attach_law(m: mujoco.MjModel, law, joint: str | None = None) -> None:
    """Make the installed callback evaluate `law` for model `m` (and for later copies of it), at the angle and
    velocity of `joint` (default `law_joint`: "abduction" (v1) if the model has it, else "shoulder_elv" (v2)); a
    length-keyed law (`tendon_law.TendonLaw`, kind "length") reads each actuator's own tendon length instead and
    takes no joint."""
    names = muscle_names(m)
    unknown = [x for x in law.actuators if x not in names]
    if unknown:
        raise ValueError(f"the model has no actuator(s) {unknown}; it has {names}")
    by_length = getattr(law, "kind", "joint") == "length"
    if by_length and joint is not None:
        raise ValueError("a length-keyed law reads each tendon's length; it takes no joint")
    joint = None if by_length else law_joint(m, joint)
    law_id = next(_law_ids)
    from shoulder_bench import native as compiled  # lazily: numba loads (or compiles) the callbacks

    # the actuator whose ctrl is each table's activation: its muscle's first table's
    ctrl_of = [names.index(law.actuators[law.first_table[k]]) for k in law.muscle_of]
    qadr = vadr = 0
    if joint is not None:
        jnt = m.joint(joint).id
        qadr, vadr = int(m.jnt_qposadr[jnt]), int(m.jnt_dofadr[jnt])
    bands = None if getattr(law, "lines", None) is None else _band_addresses(m, law, names)
    compiled.register(law_id, law, ctrl_of, qadr, vadr, bands)  # complete before actuator_user names the id
    _LAWS[law_id] = (law, joint)
    m.actuator_user[:, 0] = law_id
    m.actuator_user[:, 1] = [law.actuators.index(x) if x in law.actuators else -1 for x in names]
    _models.pop(id(m), None)
    _current[0] = (None, None, None, None)


def _band_addresses(m: mujoco.MjModel, law, names) -> tuple:
    """(actuator of each band tendon, the three coordinates' qpos and dof addresses, nu) for the passive callback;
    ValueError where the model cannot carry the law's band corrections."""
    from shoulder_bench import native as compiled
    from shoulder_bench.full_arm import COORDINATES

    joints = [m.joint(j).name for j in range(m.njnt)]
    if any(c not in joints for c in COORDINATES):
        raise ValueError(f"band corrections act about {COORDINATES}; the model's joints are {joints}")
    acts = np.array([names.index(t) for t in law.lines.tendons])
    for t, i in zip(law.lines.tendons, acts):
        # the passive callback takes the tension as MuJoCo's own actuator force, gain x ctrl + bias, and the level
        # (tma's table) at that ctrl: in [0, 1], the muscle's activation (a muscle's actuators all carry it: ld1-3)
        if not m.actuator_ctrllimited[i] or tuple(m.actuator_ctrlrange[i]) != (0.0, 1.0):
            raise ValueError(f"actuator {t!r}: a band correction needs a ctrl limited to [0, 1], the muscle's "
                             "activation")
    if not compiled.AVAILABLE:
        raise RuntimeError(f"band corrections are applied by the compiled passive callback only; {compiled.REASON}")
    if compiled.model_nu(m) != m.nu:
        raise RuntimeError(f"the native passive callback would read nu = {compiled.model_nu(m)} for a model with "
                           f"nu = {m.nu}; band corrections cannot be attached in this MuJoCo {mujoco.__version__}")
    qadr = np.array([int(m.joint(c).qposadr[0]) for c in COORDINATES])
    dadr = np.array([int(m.joint(c).dofadr[0]) for c in COORDINATES])
    return acts, qadr, dadr, m.nu


def law_of(m: mujoco.MjModel):
    """The force law the callback evaluates for model `m` (or a copy of it); KeyError if none is attached."""
    attached = _LAWS.get(int(m.actuator_user[0, 0])) if m.nu else None
    if attached is None:
        raise KeyError("model has no muscle law attached; load it with shoulder_bench.model.load_model")
    return attached[0]


def load_model(muscle_model: str = DEFAULT_MUSCLE_MODEL, muscles=None, path: Path | str = MODEL_PATH) -> mujoco.MjModel:
    """Compile the shoulder, attach the tabled force law and install the callbacks.

    muscle_model: "fem" (tables from the thin-shell FEM) or "hill"; muscles: the simulated muscles (default all
    four); the others exert no force, as if absent.
    """
    m = compile_model(path)
    attach_law(m, ForceLaw.load(muscle_model, muscles=tuple(muscles or muscle_names(m))))
    install_callbacks()
    return m


def muscle_names(m: mujoco.MjModel) -> tuple[str, ...]:
    return tuple(m.actuator(i).name for i in range(m.nu))
