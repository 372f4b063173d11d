"""The force law as compiled MuJoCo callbacks: `gain(m, d, i)` and `bias(m, d, i)` as C function pointers.

The design's "plugin-style callback": MuJoCo calls `mjcb_act_gain` / `mjcb_act_bias` for every `user` actuator at
every RK4 stage. Installed as Python functions they need the GIL (so `mujoco.rollout`'s threads cannot use them) and
cost microseconds per call; these are numba `cfunc`s, machine code with the C signature
`mjtNum f(const mjModel*, const mjData*, int)`, installed through their addresses (`mujoco.set_mjcb_act_gain` takes a
ctypes function pointer). No compiler is needed at run time: numba compiles them once and caches the machine code
(`cache=True`) beside this file. The arithmetic is `muscle.law_point`, the same inlined function the batch kernel
runs, so the two paths agree bit for bit.

What a call reads:
- From the calling model and data, through their C structs: `actuator_user` (and `nuser_actuator`) of the
  model, `qpos`, `qvel`, `ctrl` of the data, and for a length-keyed law (`tendon_law.TendonLaw`, the full
  shoulder's) `actuator_length` and `actuator_velocity` instead of qpos and qvel. The byte offsets of these
  fields in mjModel / mjData are found at import by scanning the structs of small probe models for the known
  values (`struct_offsets.find_offsets`: a pointer equal to `d.qpos.ctypes.data`, a size equal to the probe's
  `nuser_actuator`, ...), each required to be the same in three probes of different sizes; if any is not found,
  `AVAILABLE` is False, `REASON` says why and `model.install_callbacks` falls back to the Python callbacks.
- Per actuator, the law id in `actuator_user[i, 0]` and the law's column in `[i, 1]` (as `model.attach_law` writes
  them). The id is a row of the process-global registry: addresses of the law's flat table, moment arms, activation
  levels and force-velocity scales, the grid constants (a length-keyed law: per-column first knot and 1 / step),
  the law joint's qpos / dof address in that model, and, per column, the actuator whose ctrl is that column's
  activation (a muscle's first actuator: v2's ld drives ld1-3).
  An id without a row, a column outside the law or a model without user columns gives 0.0.

`passive(m, d)` is the third callback, `mjcb_passive`: for a law attached with band corrections (`band_lines`, the
3-DOF tasks' line_of_action="band") it adds each band tendon's F c(q) to qfrc_passive on the three glenohumeral
coordinates, F from `_evaluate` (the actuator's force) and c from `band_lines.band_point` (at the actuator's ctrl,
where the tendon has a level table). It also reads mjModel.nu
and mjData.qfrc_passive, and the law's row points (word BAND) to a band block: the band tendons' actuators, the
grid, the table, the band lengths, the coordinates' addresses and the nu of the model it was attached to (another nu:
nothing added), and with fibre tables ("band_fibres") the fibres' departures on their own grid. For such a law the
actuator callbacks read a band tendon's force at its band's length and lengthening rate
(`band_lines.band_lengthening`: the actuator length plus the band's length less the MJCF path's, read from the
coordinates' qpos, and the rate less the MJCF path's from their qvel), and with fibre tables in the block
(line_of_action="band_fibres") the law as the mean of the band's fibres' (`band_lines.fibre_law`).

The registry: `_ROOT` (fixed for the process; the callbacks find it through the symbol `shoulder_bench_native_root`,
which is resolved when the cached machine code is loaded, so the cache holds no address) holds the address of the
current row table; the table's first word is its capacity. Growing allocates a new table, copies the rows and then
swaps the address (one aligned 8-byte store); old tables stay allocated, so a thread that read the old address still
reads valid rows. Rows are written before the model's `actuator_user` names them and are never changed or freed: a
row and the arrays it points into (held in `_KEEP`) live as long as the process, as the law ids of `model` do. The
callbacks keep no state of their own, so any number of threads may call them at once.
"""
from __future__ import annotations

import ctypes
import threading

import llvmlite.binding as llvm
import mujoco
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from shoulder_bench.band_lines import band_cells, band_lengthening, band_level, band_point, fibre_law
from shoulder_bench.muscle import law_cell, law_point
from shoulder_bench.struct_offsets import find_offsets, words

SYMBOL = "shoulder_bench_native_root"
ROW = 17  # int64 words per registry row
# row layout (int64 words; A0 and INV_DA hold float64 bits)
VALID, FLAT, ARM, LEVELS, NIVS, CTRL_OF, NCOL, NK, NLEV, QADR, VADR, A0, INV_DA, MODE, X0, INV_DX, BAND = range(17)
JOINT_MODE, LENGTH_MODE = 0, 1  # row[MODE]: the law reads one joint's angle (ForceLaw) or each tendon's length
# row[BAND]: 0, or the address of a band block (int64 words): the law's band corrections (`band_lines`)
# BFIB, NFIB, FGRID, FSHAPE: the fibre table, its fibre count and its own grid (`BandLines.fibre_grid`), or zeros
NB, ACTS, BGRID, BSHAPE, BTABLE, BQADR, BDADR, BNU, BLEN, BFIB, NFIB, FGRID, FSHAPE = range(13)
BLOCK = 13  # int64 words per band block
# _ROOT layout
TABLE, M_USER, M_NUSER, D_QPOS, D_QVEL, D_CTRL, D_ALEN, D_AVEL, M_NU, D_QFRC_PASSIVE, M_GEAR = range(11)
ROOT_WORDS = 11

_ROOT = np.zeros(ROOT_WORDS, dtype=np.int64)
llvm.add_symbol(SYMBOL, _ROOT.ctypes.data)
_TABLES: list[np.ndarray] = []  # every row table ever made (the current one last), never freed
_KEEP: dict[int, tuple] = {}  # law id -> the arrays its row points into


@intrinsic
def _root(typingctx):
    """The address of `_ROOT`, through the external symbol (resolved when the machine code is loaded)."""
    def codegen(context, builder, sig, args):
        gv = builder.module.globals.get(SYMBOL)
        if gv is None:
            gv = ir.GlobalVariable(builder.module, ir.IntType(64), name=SYMBOL)
            gv.linkage = "external"
        return builder.ptrtoint(gv, ir.IntType(64))
    return types.int64(), codegen


def _pointer_intrinsic(target):
    @intrinsic
    def as_pointer(typingctx, address):
        sig = types.CPointer(target)(types.int64)

        def codegen(context, builder, sig, args):
            return builder.inttoptr(args[0], context.get_value_type(sig.return_type))
        return sig, codegen
    return as_pointer


_f64p = _pointer_intrinsic(types.float64)
_i64p = _pointer_intrinsic(types.int64)


@intrinsic
def _address(typingctx, pointer):
    def codegen(context, builder, sig, args):
        return builder.ptrtoint(args[0], ir.IntType(64))
    return types.int64(types.voidptr), codegen


@numba.njit(inline="always")
def _word(address):
    return numba.carray(_i64p(address), 1)[0]


@numba.njit(inline="always")
def _evaluate(m, d, i):
    """(gain, bias) of actuator i of model m in data d: -(active per unit activation x FV), -passive (muscles
    pull); (0, 0) where the actuator has no law."""
    root = numba.carray(_i64p(_root()), ROOT_WORDS)
    mp, dp = _address(m), _address(d)
    nuser = _word(mp + root[M_NUSER])
    if nuser < 2 or i < 0:  # MuJoCo passes actuator indices, 0 <= i < nu
        return 0.0, 0.0
    user = numba.carray(_f64p(_word(mp + root[M_USER])), (i + 1) * nuser)
    lid, col = user[i * nuser], user[i * nuser + 1]
    table = root[TABLE]
    capacity = _word(table)
    if not (0.0 < lid < capacity and col >= 0.0) or int(lid) != lid:  # NaN fails the comparisons
        return 0.0, 0.0
    row = numba.carray(_i64p(table + 8 * ROW * int(lid)), ROW)
    rowf = numba.carray(_f64p(table + 8 * ROW * int(lid)), ROW)
    n = row[NCOL]
    c = int(col)
    if row[VALID] != 1 or c != col or c >= n:
        return 0.0, 0.0
    nk, nlev = row[NK], row[NLEV]
    levels = numba.carray(_f64p(row[LEVELS]), nlev)
    flat = numba.carray(_f64p(row[FLAT]), nk * nlev * n)
    arm = numba.carray(_f64p(row[ARM]), (nk, n))
    nivs = numba.carray(_f64p(row[NIVS]), n)
    ctrl_of = numba.carray(_i64p(row[CTRL_OF]), n)
    ctrl = numba.carray(_f64p(_word(dp + root[D_CTRL])), ctrl_of[c] + 1)
    if row[MODE] == LENGTH_MODE:  # TendonLaw: this actuator's own tendon length and lengthening rate
        x0 = numba.carray(_f64p(row[X0]), n)
        inv_dx = numba.carray(_f64p(row[INV_DX]), n)
        length = numba.carray(_f64p(_word(dp + root[D_ALEN])), i + 1)
        speed = numba.carray(_f64p(_word(dp + root[D_AVEL])), i + 1)
        # MuJoCo's actuator length is gear x the tendon's; gear is 1 in the model, a strength draw under randomize
        gear = numba.carray(_f64p(_word(mp + root[M_GEAR])), 6 * (i + 1))[6 * i]
        scale = 1.0 / gear if gear != 0.0 else 1.0
        tendon, velocity = length[i] * scale, speed[i] * scale
        if row[BAND] != 0:  # a band tendon: its band's length and lengthening rate (`band_lines`)
            dl, dv, b = _band_state(m, d, row[BAND], i, ctrl[ctrl_of[c]])
            tendon, velocity = tendon + dl, velocity + dv
            if b >= 0 and _word(row[BAND] + 8 * NFIB) > 0:  # "band_fibres": the mean of its band's fibres' law
                per_unit, passive, fv = _fibres(d, row[BAND], b, flat, arm, levels, n, c, tendon, x0[c], inv_dx[c],
                                                nk - 1.000001, ctrl[ctrl_of[c]], velocity, nivs[c])
                return -(per_unit * fv), -passive
        i_cell, w = law_cell(tendon, x0[c], inv_dx[c], nk - 1.000001)
    else:
        qpos = numba.carray(_f64p(_word(dp + root[D_QPOS])), row[QADR] + 1)
        qvel = numba.carray(_f64p(_word(dp + root[D_QVEL])), row[VADR] + 1)
        i_cell, w = law_cell(qpos[row[QADR]], rowf[A0], rowf[INV_DA], nk - 1.000001)
        velocity = qvel[row[VADR]]
    _, per_unit, passive, fv = law_point(flat, arm, levels, n, c, i_cell, w, ctrl[ctrl_of[c]], velocity, nivs[c])
    return -(per_unit * fv), -passive


@numba.njit(inline="always")
def _band_state(m, d, address, i, a):
    """(band length less the MJCF path's, its lengthening rate less the MJCF path's) of actuator i of model m in data
    d when it is one of the band block's at `address` (`band_lines.band_lengthening`, along the line at activation a
    clipped to [0, 1]) and its index in the block; (0, 0, -1) otherwise, or for another model than the block's."""
    root = numba.carray(_i64p(_root()), ROOT_WORDS)
    mp, dp = _address(m), _address(d)
    block = numba.carray(_i64p(address), BLOCK)
    if block[BNU] != _word(mp + root[M_NU]):
        return 0.0, 0.0, -1
    nb = block[NB]
    acts = numba.carray(_i64p(block[ACTS]), nb)
    for b in range(nb):
        if acts[b] == i:
            grid = numba.carray(_f64p(block[BGRID]), 8)
            shape = numba.carray(_i64p(block[BSHAPE]), 4)
            table = numba.carray(_f64p(block[BTABLE]), (nb, shape[3], shape[0], shape[1], shape[2], 3))
            lengths = numba.carray(_f64p(block[BLEN]), (nb, 1, shape[0], shape[1], shape[2], 1))
            qadr = numba.carray(_i64p(block[BQADR]), 3)
            dadr = numba.carray(_i64p(block[BDADR]), 3)
            qpos = numba.carray(_f64p(_word(dp + root[D_QPOS])), max(qadr[0], qadr[1], qadr[2]) + 1)
            qvel = numba.carray(_f64p(_word(dp + root[D_QVEL])), max(dadr[0], dadr[1], dadr[2]) + 1)
            dl, dv = band_lengthening(lengths, table, b, min(max(a, 0.0), 1.0), qpos[qadr[0]], qpos[qadr[1]],
                                      qpos[qadr[2]], qvel[dadr[0]], qvel[dadr[1]], qvel[dadr[2]], grid, shape)
            return dl, dv, b
    return 0.0, 0.0, -1


@numba.njit(inline="always")
def _fibres(d, address, b, flat, arm, levels, n, c, length, x0, inv_dx, kmax, a, velocity, nivs):
    """`band_lines.fibre_law` for band b of the block at `address`, at data d's pose (the fibres on their own grid)."""
    block = numba.carray(_i64p(address), BLOCK)
    grid, shape = numba.carray(_f64p(block[FGRID]), 8), numba.carray(_i64p(block[FSHAPE]), 4)
    fibres = numba.carray(_f64p(block[BFIB]), (block[NB], 1, shape[0], shape[1], shape[2], block[NFIB]))
    qadr = numba.carray(_i64p(block[BQADR]), 3)
    qpos = numba.carray(_f64p(_word(_address(d) + _word(_root() + 8 * D_QPOS))), max(qadr[0], qadr[1], qadr[2]) + 1)
    return fibre_law(fibres, b, qpos[qadr[0]], qpos[qadr[1]], qpos[qadr[2]], grid, shape, flat, arm, levels, n, c,
                     length, x0, inv_dx, kmax, a, velocity, nivs)


SIGNATURE = types.float64(types.voidptr, types.voidptr, types.int32)


@numba.cfunc(SIGNATURE, nopython=True, nogil=True, cache=True)
def gain(m, d, i):
    return _evaluate(m, d, i)[0]


@numba.cfunc(SIGNATURE, nopython=True, nogil=True, cache=True)
def bias(m, d, i):
    return _evaluate(m, d, i)[1]


@numba.cfunc(types.void(types.voidptr, types.voidptr), nopython=True, nogil=True, cache=True)
def passive(m, d):
    """`mjcb_passive`: add each band tendon's F (r_band - r_MJCF) to qfrc_passive about the three coordinates
    (`band_lines`); nothing for a model whose law has no band block. F = -(gain a + bias) gear, the force MuJoCo
    applies along the tendon (a = ctrl in [0, 1], the range `model.attach_law` requires of band actuators; gear: the
    actuator's first, 1 in the model, a muscle's strength under `randomization`)."""
    root = numba.carray(_i64p(_root()), ROOT_WORDS)
    mp, dp = _address(m), _address(d)
    nu, nuser = _word(mp + root[M_NU]), _word(mp + root[M_NUSER])
    if nu < 1 or nuser < 2:
        return
    lid = numba.carray(_f64p(_word(mp + root[M_USER])), 1)[0]  # actuator 0's law id: the model's law
    table = root[TABLE]
    if not (0.0 < lid < _word(table)) or int(lid) != lid:
        return
    row = numba.carray(_i64p(table + 8 * ROW * int(lid)), ROW)
    if row[VALID] != 1 or row[BAND] == 0:
        return
    block = numba.carray(_i64p(row[BAND]), BLOCK)
    if block[BNU] != nu:  # not the model the law was attached to (a foreign model naming the id in its user data)
        return
    nb = block[NB]
    acts = numba.carray(_i64p(block[ACTS]), nb)
    grid = numba.carray(_f64p(block[BGRID]), 8)
    shape = numba.carray(_i64p(block[BSHAPE]), 4)
    corrections = numba.carray(_f64p(block[BTABLE]), (nb, shape[3], shape[0], shape[1], shape[2], 3))
    qadr = numba.carray(_i64p(block[BQADR]), 3)
    dadr = numba.carray(_i64p(block[BDADR]), 3)
    qpos = numba.carray(_f64p(_word(dp + root[D_QPOS])), max(qadr[0], qadr[1], qadr[2]) + 1)
    qfrc = numba.carray(_f64p(_word(dp + root[D_QFRC_PASSIVE])), max(dadr[0], dadr[1], dadr[2]) + 1)
    ctrl = numba.carray(_f64p(_word(dp + root[D_CTRL])), nu)
    gear = numba.carray(_f64p(_word(mp + root[M_GEAR])), 6 * nu)
    i0, w0, i1, w1, i2, w2 = band_cells(qpos[qadr[0]], qpos[qadr[1]], qpos[qadr[2]], grid, shape)
    for b in range(nb):
        i = acts[b]
        g, f0 = _evaluate(m, d, i)
        a = min(max(ctrl[i], 0.0), 1.0)
        tension = -(g * a + f0) * gear[6 * i]
        j, wj = band_level(a, grid, shape)
        for k in range(3):
            qfrc[dadr[k]] += tension * band_point(corrections, b, k, j, wj, i0, w0, i1, w1, i2, w2)


# --- the registry ----------------------------------------------------------------------------------------------------
def _grow(capacity: int) -> np.ndarray:
    """A row table of at least `capacity` rows holding the current rows; made current by one aligned store."""
    old = _TABLES[-1] if _TABLES else None
    table = np.zeros((capacity, ROW), dtype=np.int64)
    if old is not None:
        table[:len(old)] = old
    table[0, 0] = capacity  # row 0 is no law: its first word is the capacity
    _TABLES.append(table)
    _ROOT[TABLE] = table.ctypes.data
    return table


_grow(256)
_REGISTER_LOCK = threading.Lock()


def register(law_id: int, law, ctrl_of, qadr: int, vadr: int, bands: tuple | None = None) -> None:
    """Fill row `law_id` for `law` attached to a model: `ctrl_of[c]` is the actuator whose ctrl is column c's
    activation, (qadr, vadr) the law joint's qpos and dof addresses in that model; bands: None, or (actuator of each
    of `law.lines`' tendons, the three coordinates' qpos addresses, their dof addresses, the model's nu) for the
    passive callback.
    Call before the model's `actuator_user` names the id (the row is complete before any callback can read it).
    Thread-safe: writers hold `_REGISTER_LOCK`, so a table grown by one thread copies every row another has written
    (callbacks read without it)."""
    if law_id < 1:
        raise ValueError(f"law id {law_id} must be >= 1")
    with _REGISTER_LOCK:
        _register(law_id, law, ctrl_of, qadr, vadr, bands)


def _band_block(lines, bands) -> tuple[np.ndarray, tuple]:
    """The band block of a row (`passive` reads it) and the arrays it points into."""
    acts, qadr, dadr = (np.ascontiguousarray(x, dtype=np.int64) for x in bands[:3])
    arrays = (acts, np.ascontiguousarray(lines.grid, dtype=np.float64), np.ascontiguousarray(lines.shape),
              lines.table, qadr, dadr, lines.lengths)
    if acts.shape != (len(lines.tendons),) or qadr.shape != (3,) or dadr.shape != (3,) or lines.grid.shape != (8,) \
            or lines.shape.shape != (4,):
        raise ValueError("inconsistent band arrays for the native callback")
    block = np.zeros(BLOCK, dtype=np.int64)
    block[NB], block[BNU] = len(acts), bands[3]
    block[ACTS], block[BGRID], block[BSHAPE], block[BTABLE], block[BQADR], block[BDADR], block[BLEN] = (
        x.ctypes.data for x in arrays)
    if lines.fibres is not None:  # line_of_action="band_fibres"
        fibres = (np.ascontiguousarray(lines.fibres, dtype=np.float64),
                  np.ascontiguousarray(lines.fibre_grid, dtype=np.float64), np.ascontiguousarray(lines.fibre_shape))
        if fibres[1].shape != (8,) or fibres[2].shape != (4,) or fibres[0].shape[2:5] != tuple(fibres[2][:3]):
            raise ValueError("inconsistent fibre arrays for the native callback")
        arrays += fibres
        block[BFIB], block[FGRID], block[FSHAPE] = (x.ctypes.data for x in fibres)
        block[NFIB] = lines.fibres.shape[-1]
    return block, arrays


def _register(law_id: int, law, ctrl_of, qadr: int, vadr: int, bands: tuple | None) -> None:
    table = _TABLES[-1]
    while law_id >= len(table):
        table = _grow(2 * len(table))
    flat, arm, levels, a0, inv_da, nivs = law.kernel_arguments()
    length_mode = getattr(law, "kind", "joint") == "length"  # TendonLaw: a0, inv_da are per-tendon arrays
    ctrl_of = np.ascontiguousarray(ctrl_of, dtype=np.int64)
    grid = (a0, inv_da) if length_mode else (np.zeros(1), np.zeros(1))
    arrays = tuple(np.ascontiguousarray(x, dtype=np.float64) for x in (flat, arm, levels, nivs, *grid))
    flat, arm, levels, nivs, x0, inv_dx = arrays
    n = arm.shape[1]
    if ctrl_of.shape != (n,) or nivs.shape != (n,) or flat.size != arm.shape[0] * levels.size * n or \
            (length_mode and (x0.shape != (n,) or inv_dx.shape != (n,))):
        raise ValueError("inconsistent law arrays for the native callback")
    row = np.zeros(ROW, dtype=np.int64)
    row[FLAT], row[ARM], row[LEVELS], row[NIVS], row[X0], row[INV_DX] = (x.ctypes.data for x in arrays)
    row[CTRL_OF] = ctrl_of.ctypes.data
    row[NCOL], row[NK], row[NLEV], row[QADR], row[VADR] = n, arm.shape[0], levels.size, qadr, vadr
    row[MODE] = LENGTH_MODE if length_mode else JOINT_MODE
    if not length_mode:
        row[A0:INV_DA + 1] = np.array([a0, inv_da], dtype=np.float64).view(np.int64)
    kept = (*arrays, ctrl_of, law)
    if bands is not None:
        block, band_arrays = _band_block(law.lines, bands)
        row[BAND] = block.ctypes.data
        kept += (block, *band_arrays)
    _KEEP[law_id] = kept
    table[law_id, 1:] = row[1:]
    table[law_id, VALID] = 1  # last: a reader sees a complete row or none


try:
    OFFSETS = find_offsets()
    AVAILABLE, REASON = True, ""
    _ROOT[M_USER], _ROOT[M_NUSER], _ROOT[M_GEAR] = (OFFSETS[k] for k in ("actuator_user", "nuser_actuator",
                                                                          "actuator_gear"))
    _ROOT[D_QPOS], _ROOT[D_QVEL], _ROOT[D_CTRL], _ROOT[D_ALEN], _ROOT[D_AVEL], _ROOT[M_NU], _ROOT[D_QFRC_PASSIVE] = (
        OFFSETS[k] for k in ("qpos", "qvel", "ctrl", "actuator_length", "actuator_velocity", "nu", "qfrc_passive"))
except Exception as exc:  # noqa: BLE001 - any failure means: use the Python callbacks
    OFFSETS, AVAILABLE, REASON = {}, False, f"native muscle callback unavailable: {exc}"

# ctypes function pointers of the callbacks (kept here: MuJoCo holds only the raw address)
GAIN = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)(gain.address)
BIAS = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)(bias.address)
PASSIVE = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)(passive.address)


def model_nu(m: mujoco.MjModel) -> int:
    """nu as the passive callback reads it from `m` (at OFFSETS["nu"])."""
    return int(words(m._address + OFFSETS["nu"], 8)[0])
