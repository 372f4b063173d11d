"""Pathologies of the shoulder as named conditions (issue 13, first step): what each changes in the force law.

A condition is data: the muscles it removes (no force at all, active or passive: a full-thickness tear whose tendon
no longer transmits) and the muscles whose strength it scales, by `1 - <fraction option>`. Scaling multiplies a
muscle's whole tabled tendon force, active and passive alike (the tendon transmits that fraction of what the intact
muscle would), and its tabled torque; the moment arms, the force-velocity curve and the geometry are unchanged.
`ForceLaw.scaled` applies the factors to every table of a muscle (ld's three bundles).

A condition may also change the geometry (`geometry`: a key of `arm.GEOMETRIES`): `ld_transfer` re-inserts the
latissimus on the greater tuberosity, so the task loads that geometry's model (ld1-3 rerouted) and the rerouted
tendons' own tables (`arm.arm_for(condition)`; docs/surgery.md "ld_transfer").

Names compose with "+" (`posterosuperior_tear+ld_transfer`, the operation's clinical case); factors multiply; at
most one geometry. `condition=None` is the intact (pre-op) shoulder.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

FRACTIONS = {"tear_fraction": 0.5, "weakness_fraction": 0.5}  # the fraction options and their defaults
NOT_YET: dict[str, str] = {  # conditions named but not built (name -> why), refused with that reason
    "lower_trapezius_transfer": "not available: no model here has a trapezius (MoBL-ARMS, which the anatomy comes "
                                "from, models the glenohumeral muscles only; the scapula follows the humerus by its "
                                "rhythm), so there is no lower trapezius to transfer; see docs/surgery.md",
}


@dataclass(frozen=True)
class Condition:
    name: str
    description: str
    source: str
    removes: tuple[str, ...] = ()  # muscles that exert no force (active or passive)
    scales: dict[str, str] = field(default_factory=dict)  # muscle -> the fraction option: force x (1 - fraction)
    geometry: str | None = None  # a rerouting (a key of arm.GEOMETRIES): its model and the rerouted tendons' tables


CONDITIONS = {c.name: c for c in (
    Condition("ssp_tear", "full-thickness supraspinatus tear: the supraspinatus transmits no force (active or "
              "passive)", "Phillips, Kosek & Karduna 2018, J Biomech 68:65 (the supraspinatus share of abduction "
              "torque, by nerve block); issue 13", removes=("ssp",)),
    Condition("ssp_partial_tear", "partial-thickness supraspinatus tear: its tendon force (active and passive) "
              "scaled by 1 - tear_fraction", "issue 13 (strength scaled, the fraction an option)",
              scales={"ssp": "tear_fraction"}),
    Condition("posterosuperior_tear", "massive posterosuperior cuff tear: supraspinatus and infraspinatus removed "
              "(no force)", "Muench et al. 2022 (irreparable posterosuperior tear in a dynamic cadaver simulator: "
              "-24.1 deg of maximum active abduction)", removes=("ssp", "isp")),
    Condition("deltoid_weakness", "middle deltoid weakness (e.g. axillary nerve palsy): its tendon force scaled by "
              "1 - weakness_fraction", "issue 13; McCully et al. 2007, J Biomech 40:1839 (the deltoid's role when "
              "the cuff is lost)", scales={"dmi": "weakness_fraction"}),
    Condition("ld_transfer", "latissimus dorsi transfer: ld1-3 detached from the intertubercular groove and "
              "re-inserted on the greater tuberosity at the infraspinatus footprint, wrapping over the posterior "
              "humeral head; re-tensioned to their fibre stretch at the side; its own model and tables (compose "
              "with posterosuperior_tear for the operation's indication)", "Gerber et al. 1988, Clin Orthop 232:51 "
              "(the operation); Muench et al. 2022 (+8.9 deg of maximum active abduction after the transfer); "
              "issue 13 (external-rotation moment arm 6.5-10.6 mm at 0 deg abduction)", geometry="ld_transfer"),
)}


def names(condition: str | None) -> tuple[str, ...]:
    """The conditions of `condition` ("a+b"), checked: ValueError for an unknown or not-yet-available one."""
    if condition is None:
        return ()
    if not isinstance(condition, str) or not condition.strip():
        raise ValueError(f"condition must be None or a name ({', '.join(CONDITIONS)}, composed with '+'); "
                         f"got {condition!r}")
    parts = tuple(p.strip() for p in condition.split("+"))
    for p in parts:
        if p in NOT_YET:
            raise ValueError(f"condition {p!r}: {NOT_YET[p]}")
        if p not in CONDITIONS:
            raise ValueError(f"unknown condition {p!r}; valid conditions: {', '.join(CONDITIONS)} (compose with "
                             f"'+', e.g. posterosuperior_tear+deltoid_weakness); None is the intact shoulder")
    if len(set(parts)) != len(parts):
        raise ValueError(f"condition {condition!r} names a condition twice")
    return parts


def geometry(condition: str | None) -> str | None:
    """The geometry `condition` puts the shoulder in (None: the intact one); two different ones are a ValueError."""
    geos = {CONDITIONS[p].geometry for p in names(condition)} - {None}
    if len(geos) > 1:
        raise ValueError(f"condition {condition!r} combines geometries {sorted(geos)}; at most one can apply")
    return next(iter(geos), None)


def fraction(name: str, value) -> float:
    """A fraction option's value: a real number strictly between 0 and 1."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(float(value))
    if not ok or not 0.0 < float(value) < 1.0:
        raise ValueError(f"{name} must be a number in (0, 1) (the fraction of strength lost); got {value!r}")
    return float(value)


def factors(condition: str | None, muscles=None, tear_fraction=None, weakness_fraction=None) -> dict[str, float]:
    """{muscle: force factor} of `condition` for a task with `muscles` (only the muscles it changes; {} intact).

    A fraction option given for a condition that does not use it, or a condition that leaves none of the task's
    `muscles` with force (ssp_tear on abduction_ssp), is a ValueError saying so."""
    given = {"tear_fraction": tear_fraction, "weakness_fraction": weakness_fraction}
    parts = names(condition)
    used = {opt for p in parts for opt in CONDITIONS[p].scales.values()}
    for key, value in given.items():
        if value is not None:
            fraction(key, value)
            if key not in used:
                users = [c.name for c in CONDITIONS.values() if key in c.scales.values()]
                raise ValueError(f"{key} applies only with {', '.join(users)}; condition is {condition!r}")
    out: dict[str, float] = {}
    for p in parts:
        c = CONDITIONS[p]
        for m in c.removes:
            out[m] = 0.0
        for m, key in c.scales.items():
            f = FRACTIONS[key] if given[key] is None else float(given[key])
            out[m] = out.get(m, 1.0) * (1.0 - f)
    if muscles is not None:
        muscles = tuple(muscles)
        unknown = sorted(set(out) - set(muscles))
        for m in unknown:  # a condition of a muscle the task does not simulate changes nothing there
            del out[m]
        if muscles and all(out.get(m) == 0.0 for m in muscles):
            raise ValueError(f"condition {condition!r} removes {', '.join(muscles)}, which the task needs: it would "
                             f"have no muscle left; use a task with more muscles (abduction_4m)")
    return out
