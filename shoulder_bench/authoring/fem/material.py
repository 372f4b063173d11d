"""Muscle material: Blemker 2005 fibre law in a linear co-rotational plane-stress background.

Everything is written as a strain-energy density per *reference* volume so that one energy gives forces and tangent
(its derivatives, in closed form at the end of this file, held to autograd of the energy) and a line search can compare
energies. The fibre term's derivative dW/dlambda = sigma_max f / lambda_ofl is
the *nominal* fibre stress (force per undeformed area), i.e. Blemker's Cauchy stress sigma_max * f * lambda / lambda_ofl
for an incompressible sheet; taking sigma_max * f as the Cauchy stress makes the fibre force fall with stretch from
lambda = 1 and Newton fails (../shared/reference/shoulder_parameters.md).

The energies accept numpy arrays or torch tensors (they use only `where`, `exp` and min/max arithmetic); the
derivatives below are compiled scalar functions, one element at a time.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numba
import numpy as np
import torch


@dataclass(frozen=True)
class Blemker:
    """Blemker et al. 2005 (J Biomech 38:657) fibre constants, as used by the seed paper."""

    sigma_max: float = 3.0e5  # Pa, maximum isometric fibre stress
    lambda_ofl: float = 1.0  # fibre stretch at optimal fibre length (reference configuration)
    lambda_star: float = 1.4  # end of the exponential passive region
    p1: float = 0.05
    p2: float = 6.6

    @property
    def p3(self) -> float:
        """Slope of the linear passive continuation beyond lambda*."""
        return self.p1 * self.p2 * float(np.exp(self.p2 * (self.lambda_star / self.lambda_ofl - 1.0)))


@dataclass(frozen=True)
class Background:
    """Linear co-rotational, plane-stress background (the paper gives no constants), relaxed in compression.

    E = 120 kPa, just above the 10-100 kPa usually quoted for passive muscle transverse to the fibres, on purpose: on
    the descending limb of the active force-length curve the fibre tangent reaches sigma_max * min f' = -0.365
    sigma_max = -109.5 kPa (at lambda = 1.197, a = 1). The sheet stays stable along its fibres only if the background
    adds more than that, and in a wrinkled (laterally free) state it adds E. With E = 50 kPa the equilibrium loses
    ellipticity for 1.06 < lambda < 1.30 at a = 1: strain localises in single element rows and Newton fails from any
    perturbed start (docs/fem.md). nu = 0.45: nearly incompressible tissue (0.45-0.49) without the locking nu -> 0.5
    brings to constant-strain triangles.
    """

    youngs_modulus: float = 1.2e5  # Pa
    poisson_ratio: float = 0.45

    @property
    def mu(self) -> float:
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def lam(self) -> float:
        """Plane-stress Lame parameter 2 mu nu / (1 - nu)."""
        return 2.0 * self.mu * self.poisson_ratio / (1.0 - self.poisson_ratio)


@dataclass(frozen=True)
class Material:
    fibre: Blemker = Blemker()
    background: Background = Background()

    def as_dict(self) -> dict:
        return {"fibre": asdict(self.fibre), "background": asdict(self.background),
                "fibre_stretch": "lambda = |F a0| (membrane, J = 1)", "background_model": "co-rotational plane stress"}


def _lib(x):
    return torch if isinstance(x, torch.Tensor) else np


def f_passive(lh, c: Blemker = Blemker()):
    """Normalised passive fibre force at normalised stretch lh = lambda / lambda_ofl."""
    xp = _lib(lh)
    ls = c.lambda_star / c.lambda_ofl
    expo = c.p1 * (xp.exp(c.p2 * (xp.minimum(lh, ls * xp.ones_like(lh)) - 1.0)) - 1.0)
    lin = c.p1 * (np.exp(c.p2 * (ls - 1.0)) - 1.0) + c.p3 * (lh - ls)
    return xp.where(lh <= 1.0, 0.0 * lh, xp.where(lh <= ls, expo, lin))


def f_active(lh):
    """Normalised active force-length curve (piecewise quadratic, zero outside 0.4-1.6)."""
    xp = _lib(lh)
    q1 = 9.0 * (lh - 0.4) ** 2
    q2 = 1.0 - 4.0 * (1.0 - lh) ** 2
    q3 = 9.0 * (lh - 1.6) ** 2
    return xp.where((lh < 0.4) | (lh > 1.6), 0.0 * lh, xp.where(lh <= 0.6, q1, xp.where(lh < 1.4, q2, q3)))


def nominal_fibre_stress(lam, activation, c: Blemker = Blemker()):
    """Fibre force per undeformed area, Pa: sigma_max * (f_passive + a f_active) / lambda_ofl."""
    lh = lam / c.lambda_ofl
    return c.sigma_max * (f_passive(lh, c) + activation * f_active(lh)) / c.lambda_ofl


def _passive_energy(lh, c: Blemker):
    """Integral of f_passive from 1 to lh (dimensionless)."""
    xp = _lib(lh)
    ls = c.lambda_star / c.lambda_ofl
    xe = xp.minimum(xp.maximum(lh, xp.ones_like(lh)), ls * xp.ones_like(lh))
    w_exp = c.p1 * ((xp.exp(c.p2 * (xe - 1.0)) - 1.0) / c.p2 - (xe - 1.0))
    d = xp.maximum(lh - ls, 0.0 * lh)
    f_ls = c.p1 * (np.exp(c.p2 * (ls - 1.0)) - 1.0)
    return w_exp + f_ls * d + 0.5 * c.p3 * d**2


def _active_energy(lh):
    """Integral of f_active from 0.4 to lh (dimensionless)."""
    xp = _lib(lh)
    x1 = xp.minimum(xp.maximum(lh, 0.4 + 0.0 * lh), 0.6 + 0.0 * lh)
    w1 = 3.0 * (x1 - 0.4) ** 3
    x2 = xp.minimum(xp.maximum(lh, 0.6 + 0.0 * lh), 1.4 + 0.0 * lh)
    w2 = (x2 - 0.6) + (4.0 / 3.0) * ((1.0 - x2) ** 3 - 0.4**3)
    x3 = xp.minimum(xp.maximum(lh, 1.4 + 0.0 * lh), 1.6 + 0.0 * lh)
    w3 = 3.0 * ((x3 - 1.6) ** 3 + 0.2**3)
    return w1 + w2 + w3


def fibre_energy(lam, activation, c: Blemker = Blemker()):
    """Fibre strain energy per reference volume, J/m^3; its lambda-derivative is `nominal_fibre_stress`."""
    lh = lam / c.lambda_ofl
    return c.sigma_max * (_passive_energy(lh, c) + activation * _active_energy(lh))


def _safe_sqrt(x, xp):
    ok = x > 1e-30
    return xp.where(ok, xp.sqrt(xp.where(ok, x, 1.0 + 0.0 * x)), 0.0 * x)


def background_energy(tr_c, det_c, b: Background = Background(), relaxed: bool = True):
    """Co-rotational energy per reference volume from the 2x2 right Cauchy-Green tensor C = U^2.

    Taut: W = mu |U - I|^2 + lam/2 (tr U - 2)^2, with tr U = sqrt(tr C + 2 sqrt(det C)) and
    |U - I|^2 = tr C - 2 tr U + 2 (no polar decomposition needed). With `relaxed` (tension-field theory, Pipkin
    1986) the sheet carries no compression: where the smaller principal stress would be negative it wrinkles,
    W = E/2 e1^2 (uniaxial tension along the larger principal strain e1), and it is slack, W = 0, when e1 <= 0.
    The three pieces join with continuous first derivatives. Without relaxation a membrane is unstable in
    compression (it buckles without bending stiffness), which is where shortening muscles at low activation are.
    """
    xp = _lib(tr_c)
    det_u = xp.sqrt(det_c)
    tr_u = xp.sqrt(tr_c + 2.0 * det_u)
    taut = b.mu * (tr_c - 2.0 * tr_u + 2.0) + 0.5 * b.lam * (tr_u - 2.0) ** 2
    if not relaxed:
        return taut
    root = _safe_sqrt(tr_u**2 - 4.0 * det_u, xp)
    e1 = 0.5 * (tr_u + root) - 1.0
    e2 = 0.5 * (tr_u - root) - 1.0
    nu = b.poisson_ratio
    wrinkled = 0.5 * b.youngs_modulus * e1**2
    return xp.where(e2 >= -nu * e1, taut, xp.where(e1 > 0.0, wrinkled, 0.0 * e1))


# -- closed-form derivatives, compiled (numba), for the Newton solves (fem.membrane) -----------------------------------
# The same functions as the energies above, differentiated by hand, one element at a time: torch autograd of the
# energies took 42 % of a band solve, and the same closed form as numpy array code still spent most of its time in
# numpy's per-call overhead on ~500 elements (docs/fem.md "Newton"). tests/test_membrane.py holds these to autograd of
# the energies, on every branch. The parameters come as plain floats (`fibre_parameters`, `background_parameters`).


def fibre_parameters(c: Blemker) -> tuple:
    return (c.sigma_max, c.lambda_ofl, c.lambda_star, c.p1, c.p2, c.p3)


def background_parameters(b: Background) -> tuple:
    return (b.mu, b.lam, b.youngs_modulus, b.poisson_ratio)


@numba.njit(cache=True, error_model="numpy", inline="always")
def fibre_point(lam, activation, sigma_max, lambda_ofl, lambda_star, p1, p2, p3):
    """`fibre_energy` and its first and second derivatives in lambda at one stretch: (W, W', W'')."""
    lh, ls = lam / lambda_ofl, lambda_star / lambda_ofl
    xe = min(max(lh, 1.0), ls)
    d = max(lh - ls, 0.0)
    f_ls = p1 * (np.exp(p2 * (ls - 1.0)) - 1.0)
    w_passive = p1 * ((np.exp(p2 * (xe - 1.0)) - 1.0) / p2 - (xe - 1.0)) + f_ls * d + 0.5 * p3 * d * d
    x1, x2, x3 = min(max(lh, 0.4), 0.6), min(max(lh, 0.6), 1.4), min(max(lh, 1.4), 1.6)
    w_active = 3.0 * (x1 - 0.4) ** 3 + (x2 - 0.6) + (4.0 / 3.0) * ((1.0 - x2) ** 3 - 0.4**3) \
        + 3.0 * ((x3 - 1.6) ** 3 + 0.2**3)
    if lh <= 1.0:
        f_p, s_p = 0.0, 0.0
    elif lh <= ls:
        f_p, s_p = p1 * (np.exp(p2 * (lh - 1.0)) - 1.0), p1 * p2 * np.exp(p2 * (lh - 1.0))
    else:
        f_p, s_p = f_ls + p3 * (lh - ls), p3
    if lh < 0.4 or lh > 1.6:
        f_a, s_a = 0.0, 0.0
    elif lh <= 0.6:
        f_a, s_a = 9.0 * (lh - 0.4) ** 2, 18.0 * (lh - 0.4)
    elif lh < 1.4:
        f_a, s_a = 1.0 - 4.0 * (1.0 - lh) ** 2, 8.0 * (1.0 - lh)
    else:
        f_a, s_a = 9.0 * (lh - 1.6) ** 2, 18.0 * (lh - 1.6)
    return (sigma_max * (w_passive + activation * w_active), sigma_max * (f_p + activation * f_a) / lambda_ofl,
            sigma_max * (s_p + activation * s_a) / lambda_ofl**2)


@numba.njit(cache=True, error_model="numpy", inline="always")
def background_point(tr_c, det_c, mu, lam, youngs_modulus, poisson_ratio):
    """`background_energy` (relaxed) and its derivatives in (tr C, det C) at one element: (W, W_t, W_d, W_tt, W_td,
    W_dd). Through s = sqrt(det C) and tr U = u = sqrt(tr C + 2 s); the wrinkled piece through e1 = (u + r) / 2 - 1
    with r = sqrt(u^2 - 4 s) = sqrt(tr C - 2 s), the difference of the principal stretches. Each piece where it
    applies."""
    s = np.sqrt(det_c)
    u = np.sqrt(tr_c + 2.0 * s)
    q = u * u - 4.0 * s
    root = np.sqrt(q) if q > 1e-30 else 0.0 * q
    e1, e2 = 0.5 * (u + root) - 1.0, 0.5 * (u - root) - 1.0
    u_t, u_s, u_tt, u_ts, u_ss = 0.5 / u, 1.0 / u, -0.25 / u**3, -0.5 / u**3, -1.0 / u**3
    if e2 >= -poisson_ratio * e1:  # taut: W = mu (tr - 2 u + 2) + lam/2 (u - 2)^2
        w_u = -2.0 * mu + lam * (u - 2.0)
        w = mu * (tr_c - 2.0 * u + 2.0) + 0.5 * lam * (u - 2.0) ** 2
        g_t, g_s = mu + w_u * u_t, w_u * u_s
        h_tt, h_ts, h_ss = lam * u_t**2 + w_u * u_tt, lam * u_t * u_s + w_u * u_ts, lam * u_s**2 + w_u * u_ss
    elif e1 > 0.0:  # wrinkled: W = E/2 e1^2
        r = root
        e_t, e_s = 0.5 * (u_t + 0.5 / r), 0.5 * (u_s - 1.0 / r)
        e_tt, e_ts, e_ss = 0.5 * (u_tt - 0.25 / r**3), 0.5 * (u_ts + 0.5 / r**3), 0.5 * (u_ss - 1.0 / r**3)
        y = youngs_modulus
        w = 0.5 * y * e1**2
        g_t, g_s = y * e1 * e_t, y * e1 * e_s
        h_tt, h_ts, h_ss = y * (e_t**2 + e1 * e_tt), y * (e_t * e_s + e1 * e_ts), y * (e_s**2 + e1 * e_ss)
    else:  # slack
        w, g_t, g_s, h_tt, h_ts, h_ss = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    s_d, s_dd = 0.5 / s, -0.25 / s**3  # (tr, s) -> (tr, det)
    return w, g_t, g_s * s_d, h_tt, h_ts * s_d, h_ss * s_d**2 + g_s * s_dd
