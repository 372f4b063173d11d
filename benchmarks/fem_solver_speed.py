"""The FEM solver's speed, side by side in one run (docs/fem.md "Newton"):

    .venv/bin/python benchmarks/fem_solver_speed.py [--tendon T ...] [--poses N] [--full-tendon T] [--repeats R]
        [--elements T ...] [--kernels] [--layouts A B] [--max-iter A B] [--topology-cache] [--fallback]

1. How the sheets' Newton systems are factorised (`MuscleProblem.layout`, `assembly.LAYOUTS`; `--layouts A B`,
   default COLAMD NATURAL): SuperLU with COLAMD (SciPy's default) or the natural order, LAPACK's banded LU
   (BANDED_LU), or its banded Cholesky where positive definite, else LU (BANDED, in use). For each band tendon, N of
   its table's grid poses (evenly spaced through the grid) solved as `fem build --bands` solves them
   (`bands.solve_poses`, full sheets); for --full-tendon, its length-keyed sheet as `fem build --full` solves it
   (every length and activation of its table). Each with either layout, alternating, `--repeats` times: the best wall
   time of each, their ratio, and the largest difference between the two layouts' results (moment arms in mm; forces
   in N), which is rounding if the layouts take the same Newton steps.
2. The element kernels of every tangent, on T elements (`--elements`: 480, a full footprint band; 2,048, a 33 x 33
   length-keyed sheet): d2W/dc2 by autograd in one batched reverse pass against three passes; the energy's
   derivatives in closed form, compiled (`ElementKernel.derivatives`), against autograd
   (`membrane.autograd_derivatives`); and the whole element pass (`ElementKernel.evaluate`: the energy, the gradient and
   with Hessians the 9 x 9 element blocks, one compiled loop over the elements) against the same in numpy array code
   around autograd's derivatives (`autograd_pass`, as the solver was before the closed form), on a randomly strained
   flat sheet; the best of 50 calls each, their ratio and the largest difference.
3. The same in whole solves (`--kernels`): each band tendon's N grid poses solved with the compiled pass and with
   `autograd_pass` swapped in, alternating, `--repeats` times: best wall times, ratio, and the largest difference of
   the results (the tangents differ by rounding, so Newton's iterates part within the solver's tolerance, not to
   rounding).
4. Newton's iteration cap in the band solves (`--max-iter A B`: `footprint.SETTINGS.max_iter`): each band tendon's N
   grid poses solved with either cap, alternating; a step whose Newton fails is halved (`MuscleProblem.step`), so a
   lower cap gives up sooner on a wandering solve; the largest difference of the results shows whether the
   equilibria found are the same.
5. The sheet's connectivity worked out once (`--topology-cache`; `solver.sheet_topology`): each band tendon's N grid
   poses solved with its cache and with a cache that keeps nothing (every problem works out its regularisation and
   predictor weight anew, as before), alternating; the results should not differ at all.
6. The starts' fallback (`--fallback`; `bands.FALLBACK`): each band tendon's N grid poses solved with its tendons
   (where the ramp finds no equilibrium, the least energy of the six starts beside the pose) and without, alternating:
   what the rule costs a table (e.g. `--tendon pec2 --poses 840`: its whole grid) and where it changes the results
   (only where the ramp fails, so the arms at the poses both solve are identical).
"""
from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import torch
from reset_speed import best_ms  # this folder's: the best of repeated calls, ms

from shoulder_bench.authoring.fem import bands, footprint, full, solver
from shoulder_bench.authoring.fem.assembly import LAYOUTS
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.membrane import (
    ElementKernel,
    Membrane,
    autograd_derivatives,
    element_dofs,
    energy_density,
    membrane_kinematics,
)
from shoulder_bench.authoring.fem.shells import grid_triangles
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


def autograd_pass(kernel: ElementKernel, mem: Membrane, x: np.ndarray, activation: float, hessian: bool):
    """`ElementKernel.evaluate` as numpy array code around torch autograd's derivatives (the solver before the
    closed form; the chain rule as it was written before it was compiled)."""
    b, f1, f2, c = membrane_kinematics(mem, x)
    w, dw, d2w = autograd_derivatives(c, activation, kernel.material)
    vol = mem.area * mem.thickness
    dc = np.stack([2.0 * b[:, :, 0, None] * f1[:, None], 2.0 * b[:, :, 1, None] * f2[:, None],
                   b[:, :, 0, None] * f2[:, None] + b[:, :, 1, None] * f1[:, None]], axis=2)  # (T, a, i, d)
    ge = vol[:, None, None] * np.einsum("ti,taid->tad", dw, dc)
    g = np.bincount(element_dofs(mem).ravel(), weights=ge.reshape(-1), minlength=3 * mem.n_nodes)
    if not hessian:
        return float(np.sum(vol * w)), g, None
    t = len(dc)
    h_mat = (dc.transpose(0, 1, 3, 2).reshape(t, 9, 3) @ d2w @ dc.transpose(0, 2, 1, 3).reshape(t, 3, 9))
    s = (2.0 * dw[:, 0, None, None] * b[:, :, None, 0] * b[:, None, :, 0]
         + 2.0 * dw[:, 1, None, None] * b[:, :, None, 1] * b[:, None, :, 1]
         + dw[:, 2, None, None] * (b[:, :, None, 0] * b[:, None, :, 1] + b[:, :, None, 1] * b[:, None, :, 0]))
    h_geo = (s[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]).reshape(t, 9, 9)
    return float(np.sum(vol * w)), g, vol[:, None, None] * (h_mat + h_geo)


def swapping(label: str, owner, name: str, values: dict, run, difference, repeats: int) -> None:
    """`side_by_side` of `values` ({variant: value}) each set as `owner.name` in turn; the attribute restored after."""
    kept = getattr(owner, name)
    variants = {k: (lambda v=v: setattr(owner, name, v)) for k, v in values.items()}
    try:
        side_by_side(label, variants, run, difference, repeats)
    finally:
        setattr(owner, name, kept)


def compiled_or_autograd(label: str, run, difference, repeats: int) -> None:
    """`run` with the compiled pass and with `autograd_pass` in its place (ElementKernel.evaluate swapped)."""
    swapping(label, ElementKernel, "evaluate", {"autograd": autograd_pass, "compiled": ElementKernel.evaluate}, run,
             difference, repeats)


def iteration_caps(label: str, run, difference, repeats: int, caps) -> None:
    kept = footprint.SETTINGS
    swapping(f"{label} (in use: {kept.max_iter})", footprint, "SETTINGS",
             {f"cap {c}": dataclasses.replace(kept, max_iter=c) for c in caps}, run, difference, repeats)


class Forgetful(dict):
    """A cache that keeps nothing."""

    def __setitem__(self, key, value) -> None:
        pass


def topology_cache(label: str, run, difference, repeats: int) -> None:
    swapping(label, solver, "TOPOLOGY_CACHE", {"uncached": Forgetful(), "cached": solver.TOPOLOGY_CACHE}, run,
             difference, repeats)


def fallback(label: str, run, difference, repeats: int) -> None:
    swapping(f"{label} (FALLBACK: {', '.join(bands.FALLBACK)})", bands, "FALLBACK",
             {"ramp alone": (), "with FALLBACK": bands.FALLBACK}, run, difference, repeats)


def arms(a: dict, b: dict) -> str:
    both = a["converged"] & b["converged"]
    solved = f"{a['converged'].sum()}/{b['converged'].sum()} solved"
    return f"{np.max(np.abs(a['fem_m'][both] - b['fem_m'][both])) * 1e3:.1e} mm ({solved})"


def strained_sheet(t: int, rng) -> tuple[Membrane, np.ndarray]:
    """A flat fibre sheet of about t elements (a square grid of nodes) and a random strain of it."""
    n = int(round(np.sqrt(t / 2.0))) + 1
    u, v = np.meshgrid(np.linspace(0.0, 0.05, n), np.linspace(0.0, 0.05, n), indexing="ij")
    nodes = np.stack([u.ravel(), v.ravel(), np.zeros(u.size)], axis=1)
    tri = grid_triangles(n, n)
    mem = Membrane.from_mesh(nodes, tri, np.tile([1.0, 0.0, 0.0], (len(tri), 1)), 0.002)
    x = nodes @ np.array([[1.2, 0.0, 0.02], [0.1, 1.05, 0.0], [0.0, 0.0, 1.0]]).T
    return mem, x + 2e-4 * rng.normal(size=x.shape)


def kernels(t: int) -> None:
    rng = np.random.default_rng(0)
    c = np.stack([1.0 + 0.3 * rng.random(t), 1.0 + 0.1 * rng.normal(size=t), 0.05 * rng.normal(size=t)], axis=1)
    kernel = ElementKernel(Material())
    mem, x = strained_sheet(t, rng)

    def three_passes():
        ct = torch.from_numpy(c).requires_grad_(True)
        (dw,) = torch.autograd.grad(energy_density(ct, 1.0, kernel.material).sum(), ct, create_graph=True)
        return torch.stack([torch.autograd.grad(dw[:, i].sum(), ct, retain_graph=i < 2)[0] for i in range(3)],
                           dim=1).numpy()

    def autograd():
        return autograd_derivatives(c, 1.0, kernel.material)[2]

    def passes(hessian: bool):
        pick = 2 if hessian else 1
        return (lambda: autograd_pass(kernel, mem, x, 1.0, hessian)[pick],
                lambda: kernel.evaluate(mem, x, 1.0, hessian)[pick])

    for label, old, new in (("d2W/dc2 by autograd", three_passes, autograd),
                            ("d2W/dc2 in closed form", autograd, lambda: kernel.derivatives(c, 1.0)[2]),
                            ("element pass, gradient", *passes(False)),
                            ("element pass, Hessians", *passes(True))):
        a, b = best_ms(old, 50), best_ms(new, 50)
        scale = np.max(np.abs(old()))
        print(f"{label:<34} {len(c) if 'd2W' in label else len(mem.triangles):5d} elements: before {a:6.3f} ms  "
              f"now {b:6.3f} ms  ratio {a / b:5.2f} x  largest difference {np.max(np.abs(old() - new())) / scale:.1e} "
              "of the largest entry", flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tendon", nargs="+", choices=bands.FOOTPRINT_TENDONS, default=["ssp", "tma", "pec1", "dpo"])
    p.add_argument("--poses", type=int, default=6, help="grid poses per band tendon (default 6)")
    p.add_argument("--full-tendon", default="ssp", choices=[*full.specs(), "none"],
                   help="a length-keyed sheet of the full model (default ssp; 'none' to skip)")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--elements", type=int, nargs="+", default=[480, 2048], help="element counts for the kernels")
    p.add_argument("--kernels", action="store_true",
                   help="whole solves with the compiled pass against autograd's (3.) instead of the layouts (1.)")
    p.add_argument("--layouts", nargs=2, choices=LAYOUTS, default=["COLAMD", "NATURAL"], metavar="LAYOUT",
                   help=f"the two layouts of 1. ({', '.join(LAYOUTS)}; default COLAMD NATURAL)")
    p.add_argument("--max-iter", type=int, nargs=2, metavar="CAP",
                   help="band solves with Newton's iteration cap A against B (4.) instead of the layouts (1.)")
    p.add_argument("--topology-cache", action="store_true",
                   help="band solves with the sheets' connectivity cached against not (5.) instead of the layouts (1.)")
    p.add_argument("--fallback", action="store_true",
                   help="band solves with bands.FALLBACK against the ramp alone (6.) instead of the layouts (1.)")
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
            compiled_or_autograd(f"band {t}, {len(poses)} poses", run, arms, args.repeats)
        elif args.max_iter:
            iteration_caps(f"band {t}, {len(poses)} poses", run, arms, args.repeats, args.max_iter)
        elif args.topology_cache:
            topology_cache(f"band {t}, {len(poses)} poses", run, arms, args.repeats)
        elif args.fallback:
            fallback(f"band {t}, {len(poses)} poses", run, arms, args.repeats)
        else:
            compare(f"band {t}, {len(poses)} poses", footprint._Problem, run, arms, args.repeats, args.layouts)
    if args.full_tendon != "none" and not (args.max_iter or args.topology_cache or args.fallback):
        spec = full.specs()[args.full_tendon]
        lengths = full.length_grids()[args.full_tendon]
        label = f"length-keyed {args.full_tendon}, {len(lengths)} lengths"
        run = lambda: solve(spec, lengths - spec.l_ts, "full", Material(), SETTINGS)  # noqa: E731
        forces = lambda a, b: f"{np.max(np.abs(a['force'] - b['force'])):.1e} N"  # noqa: E731
        if args.kernels:
            compiled_or_autograd(label, run, forces, args.repeats)
        else:
            compare(label, SheetProblem, run, forces, args.repeats, args.layouts)


if __name__ == "__main__":
    main()
