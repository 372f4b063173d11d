"""The byte offsets of the mjModel / mjData fields the compiled callbacks read (`shoulder_bench.native`), found in
this MuJoCo build by scanning the structs of three small probe models for known values (`find_offsets`): a pointer
equal to `d.qpos.ctypes.data`, a size equal to the probe's `nuser_actuator`, ...; each required at one offset in all
three probes."""
from __future__ import annotations

import ctypes

import mujoco
import numpy as np

_PROBES = ((2, 3, 4), (3, 5, 6), (4, 7, 9))  # (hinge joints, actuators, nuser_actuator) of the three probes
SCAN_LIMIT = 1 << 20  # bytes: the fields searched lie far inside both structs
POINTER_RUN = 256  # bytes after a pointer's first match within which later fields may share its value


def _probe(joints: int, actuators: int, nuser: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
    bodies = "".join(f'<body><joint name="j{k}"/><geom size="0.1" mass="1"/>' for k in range(joints))
    acts = "".join(f'<general joint="j{k % joints}"/>' for k in range(actuators))
    m = mujoco.MjModel.from_xml_string(f'<mujoco><size nuser_actuator="{nuser}"/><worldbody>{bodies}'
                                       f'{"</body>" * joints}</worldbody><actuator>{acts}</actuator></mujoco>')
    return m, mujoco.MjData(m)


def words(address: int, nbytes: int) -> np.ndarray:
    return np.frombuffer(ctypes.string_at(address, nbytes), dtype=np.int64)


def _matches(address: int, value: int, pointer: bool) -> list[int]:
    """Byte offsets of the 8-byte words equal to `value` in the struct at `address`: all of them for a size
    (searched in the first 64 KiB), for a pointer the last of those within POINTER_RUN bytes of its first match
    (zero-size arrays just before it share its address and come before it)."""
    if not pointer:
        return [int(k) * 8 for k in np.flatnonzero(words(address, 1 << 16) == value)]
    chunk = 4096
    for start in range(0, SCAN_LIMIT, chunk):
        hits = np.flatnonzero(words(address + start, chunk) == value)
        if hits.size:
            first = start + 8 * int(hits[0])
            run = np.flatnonzero(words(address + first, POINTER_RUN) == value)
            return [first + 8 * int(run[-1])]
    return []


def find_offsets() -> dict[str, int]:
    """Byte offsets of mjModel.actuator_user / actuator_gear / nuser_actuator / nu and mjData.qpos / qvel / ctrl /
    actuator_length / actuator_velocity / qfrc_passive in this MuJoCo, from three probe models of different sizes;
    RuntimeError if a field is not found at one offset in all three. nu: the first size field equal to the probes'
    actuator count (mjModel's nu precedes nactuator and nout, which equal it for the single-output actuators of these
    models; `model.attach_law` checks the offset against each model it attaches band corrections to)."""
    found: dict[str, set] = {}
    for joints, actuators, nuser in _PROBES:
        m, d = _probe(joints, actuators, nuser)
        targets = {"actuator_user": (m._address, m.actuator_user.ctypes.data, True),
                   "actuator_gear": (m._address, m.actuator_gear.ctypes.data, True),
                   "nuser_actuator": (m._address, nuser, False), "nu": (m._address, m.nu, False),
                   "qfrc_passive": (d._address, d.qfrc_passive.ctypes.data, True),
                   "qpos": (d._address, d.qpos.ctypes.data, True), "qvel": (d._address, d.qvel.ctypes.data, True),
                   "ctrl": (d._address, d.ctrl.ctypes.data, True),
                   "actuator_length": (d._address, d.actuator_length.ctypes.data, True),
                   "actuator_velocity": (d._address, d.actuator_velocity.ctypes.data, True)}
        for name, (address, value, pointer) in targets.items():
            hits = set(_matches(address, value, pointer))
            found[name] = hits if name not in found else found[name] & hits
    found["nu"] = {min(found["nu"])} if found["nu"] else found["nu"]
    bad = [name for name, hits in found.items() if len(hits) != 1]
    if bad:
        raise RuntimeError(f"MuJoCo {mujoco.__version__}: the struct offsets of {bad} were not found uniquely "
                           "in the probe models")
    return {name: hits.pop() for name, hits in found.items()}
