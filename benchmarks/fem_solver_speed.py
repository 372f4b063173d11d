"""The FEM solver's speed, side by side in one run (docs/fem.md "Newton"):

    .venv/bin/python benchmarks/fem_solver_speed.py [--tendon T ...] [--poses N] [--full-tendon T] [--repeats R]
        [--elements T ...] [--kernels] [--layouts A B]

1. How the sheets' Newton systems are factorised (`MuscleProblem.layout`, `assembly.LAYOUTS`; `--layouts A B`,
   default COLAMD NATURAL): SuperLU with COLAMD (SciPy's default, the length-keyed sheets') or the natural order, or
   LAPACK's banded LU (BANDED, the footprint sheets'). For each band tendon, N of its table's
   grid poses (evenly spaced through the grid) solved as `fem build --bands` solves them (`bands.solve_poses`, full
   sheets); for --full-tendon, its length-keyed sheet as `fem build --full` solves it (every length and activation of
   its table). Each with either layout, alternating, `--repeats` times: the best wall time of each, their ratio, and
   the largest difference between the two layouts' results (moment arms in mm; forces in N), which is rounding if
   the layouts take the same Newton steps.
2. The element kernels of every tangent (`membrane.membrane_tangent`), on T elements at random strains (`--elements`:
   480, a full footprint band; 2,048, a 33 x 33 length-keyed sheet): the material part of the element Hessians as
   batched matrix products against the one-call einsum, d2W/dc2 by autograd in one batched reverse pass against
   three passes, and the energy's derivatives in closed form (`ElementKernel`) against autograd
   (`membrane.autograd_derivatives`); the best of 50 calls each, their ratio and the largest difference.
3. The same in whole solves (`--kernels`): each band tendon's N grid poses solved with the closed-form kernel and with
   autograd swapped in, alternating, `--repeats` times: best wall times, ratio, and the largest difference of the
   results (the tangents differ by rounding, so Newton's iterates part within the solver's tolerance, not to
   rounding).
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from reset_speed import best_ms  # this folder's: the best of repeated calls, ms

from shoulder_bench.authoring.fem import bands, footprint, full
from shoulder_bench.authoring.fem.assembly import LAYOUTS
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.membrane import (
    ElementKernel,
    _material_blocks,
    autograd_derivatives,
    energy_density,
)
from shoulder_bench.authoring.fem.v2 import SETTINGS, solve
from shoulder_bench.authoring.fem.v2_sheet import SheetProblem


def timed(run):
    t0 = time.perf_counter()
    out = run()
    return time.perf_counter() - t0, out


def side_by_side(label: str, variants: dict, run, difference, repeats: int) -> None:
    """`run` under each of two variants (name -> a function that sets it up), alternating `repeats` times: the best
    wall time of each, their ratio (the first's over the second's) and the largest difference of the results."""
    best, outs = {v: np.inf for v in variants}, {}
    for _ in range(repeats):
        for name, setup in variants.items():
            setup()
            seconds, outs[name] = timed(run)
            best[name] = min(best[name], seconds)
    a, b = variants
    print(f"{label:<34} {a} {best[a]:7.2f} s  {b} {best[b]:7.2f} s  ratio {best[a] / best[b]:.2f} x  largest "
          f"difference {difference(*outs.values())}", flush=True)


def compare(label: str, problem: type, run, difference, repeats: int, layouts) -> None:
    kept = problem.layout
    variants = {o: (lambda o=o: setattr(problem, "layout", o)) for o in layouts}
    side_by_side(f"{label} (in use: {kept.lower()})", variants, run, difference, repeats)
    problem.layout = kept


def closed_form_or_autograd(label: str, run, difference, repeats: int) -> None:
    """`run` with the closed-form kernel and with autograd in its place (ElementKernel.derivatives swapped)."""
    closed = ElementKernel.derivatives

    def autograd(self, c, activation, second=True):
        w, dw, d2w = autograd_derivatives(c, activation, self.material)
        return w, dw, d2w if second else None

    variants = {"autograd": lambda: setattr(ElementKernel, "derivatives", autograd),
                "closed form": lambda: setattr(ElementKernel, "derivatives", closed)}
    try:
        side_by_side(label, variants, run, difference, repeats)
    finally:
        ElementKernel.derivatives = closed


def arms(a: dict, b: dict) -> str:
    both = a["converged"] & b["converged"]
    solved = f"{a['converged'].sum()}/{b['converged'].sum()} solved"
    return f"{np.max(np.abs(a['fem_m'][both] - b['fem_m'][both])) * 1e3:.1e} mm ({solved})"


def kernels(t: int) -> None:
    rng = np.random.default_rng(0)
    dc, d2w = rng.normal(size=(t, 3, 3, 3)), rng.normal(size=(t, 3, 3))
    c = np.stack([1.0 + 0.3 * rng.random(t), 1.0 + 0.1 * rng.normal(size=t), 0.05 * rng.normal(size=t)], axis=1)
    kernel = ElementKernel(Material())

    def einsum():
        return np.einsum("tij,taid,tbje->tadbe", d2w, dc, dc)

    def three_passes():
        ct = torch.from_numpy(c).requires_grad_(True)
        (dw,) = torch.autograd.grad(energy_density(ct, 1.0, kernel.material).sum(), ct, create_graph=True)
        return torch.stack([torch.autograd.grad(dw[:, i].sum(), ct, retain_graph=i < 2)[0] for i in range(3)],
                           dim=1).numpy()

    def autograd():
        return autograd_derivatives(c, 1.0, kernel.material)[2]

    for label, old, new in (("element Hessians, material part", einsum, lambda: _material_blocks(d2w, dc)),
                            ("d2W/dc2 by autograd", three_passes, autograd),
                            ("d2W/dc2 in closed form", autograd, lambda: kernel.derivatives(c, 1.0)[2])):
        a, b = best_ms(old, 50), best_ms(new, 50)
        print(f"{label:<34} {t:5d} elements: before {a:6.3f} ms  now {b:6.3f} ms  ratio {a / b:5.2f} x  largest "
              f"difference {np.max(np.abs(old() - new())):.1e}", flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tendon", nargs="+", choices=bands.FOOTPRINT_TENDONS, default=["ssp", "tma", "pec1", "dpo"])
    p.add_argument("--poses", type=int, default=6, help="grid poses per band tendon (default 6)")
    p.add_argument("--full-tendon", default="ssp", choices=[*full.specs(), "none"],
                   help="a length-keyed sheet of the full model (default ssp; 'none' to skip)")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--elements", type=int, nargs="+", default=[480, 2048], help="element counts for the kernels")
    p.add_argument("--kernels", action="store_true",
                   help="whole solves with the closed-form kernel against autograd (3.) instead of the layouts (1.)")
    p.add_argument("--layouts", nargs=2, choices=LAYOUTS, default=["COLAMD", "NATURAL"], metavar="LAYOUT",
                   help=f"the two layouts of 1. ({', '.join(LAYOUTS)}; default COLAMD NATURAL)")
    args = p.parse_args()
    if min(args.poses, args.repeats, *args.elements) < 1:
        p.error("--poses, --repeats and --elements take positive counts")
    for t in args.elements:
        kernels(t)
    for t in args.tendon:
        grid = bands.grid_poses(t)
        poses = grid[np.linspace(0, len(grid) - 1, args.poses).astype(int)]
        run = lambda t=t, poses=poses: bands.solve_poses(t, poses, "full")  # noqa: E731
        if args.kernels:
            closed_form_or_autograd(f"band {t}, {len(poses)} poses", run, arms, args.repeats)
        else:
            compare(f"band {t}, {len(poses)} poses", footprint._Problem, run, arms, args.repeats, args.layouts)
    if args.full_tendon != "none":
        spec = full.specs()[args.full_tendon]
        lengths = full.length_grids()[args.full_tendon]
        label = f"length-keyed {args.full_tendon}, {len(lengths)} lengths"
        run = lambda: solve(spec, lengths - spec.l_ts, "full", Material(), SETTINGS)  # noqa: E731
        forces = lambda a, b: f"{np.max(np.abs(a['force'] - b['force'])):.1e} N"  # noqa: E731
        if args.kernels:
            closed_form_or_autograd(label, run, forces, args.repeats)
        else:
            compare(label, SheetProblem, run, forces, args.repeats, args.layouts)


if __name__ == "__main__":
    main()
