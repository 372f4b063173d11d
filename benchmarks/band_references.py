"""A footprint sheet's taut band's moment arms beside its MJCF tendon's and the three MoBL-family references'
(docs/fem.md "The deltoids"): along elevation 0-120 deg at one plane of elevation and axial rotation on the
references' grid, girdle coupled (the condition `model validate` judges), each band solved at the pose
(`footprint.FootprintSheet`, full resolution, the contact surface of its band table `bands.surface`, rest="pose",
a = 1), not read from a table.

    python benchmarks/band_references.py --tendon dmi --plane 30 --rotation 0

The references are model outputs, not cadaver data (models/reference/README.md); the MJCF path is one of them
(MyoArm's, or the parent's or the OpenSim file's: `mobl_data.PATH_SOURCE`), so its row beside that one is a tautology.
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench.authoring import mobl_data, references
from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.footprint import TENDONS, FootprintSheet

COORDINATES = ("elv_angle", "shoulder_elv", "shoulder_rot")  # plane, elevation, rotation: the band's order
ELEVATIONS = np.arange(0.0, 121.0, 10.0)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tendon", choices=TENDONS, required=True)
    p.add_argument("--plane", type=int, choices=(-30, 0, 30, 60, 90), default=30)
    p.add_argument("--rotation", type=int, choices=(-45, 0, 30), default=0)
    p.add_argument("--coordinate", choices=COORDINATES, default="shoulder_elv")
    args = p.parse_args(argv)
    k, bundle = COORDINATES.index(args.coordinate), mobl_data.FULL_MUSCLES[args.tendon]  # DELT2 for dmi, ...
    sheet = FootprintSheet(args.tendon, "full", surface=bands.surface(args.tendon), rest="pose")
    band, mjcf, contact = [], [], []
    for e in ELEVATIONS:
        pose = (float(args.plane), float(e), float(args.rotation))
        s = sheet.solve(pose)
        band.append(1e3 * s["moment_arm_m"][k])
        mjcf.append(1e3 * sheet.mjcf_moment_arm(pose)[k])
        contact.append(s["contact_N"])
    tables = references.load()
    rows = {"band (FEM)": band, "MJCF": mjcf}
    for model in references.REFERENCES:
        rows[references.SHORT[model]] = tables.raw_curve(model, bundle, args.coordinate, args.plane,
                                                         "coupled", ELEVATIONS, args.rotation)
    print(f"{args.tendon} ({bundle}) moment arm about {args.coordinate} (mm), plane {args.plane} deg, "
          f"rotation {args.rotation} deg, girdle coupled; band on {bands.SURFACE_TEXT[bands.surface(args.tendon)]}")
    print(f"{'elevation':>12}" + "".join(f"{e:7.0f}" for e in ELEVATIONS))
    for name, r in rows.items():
        print(f"{name:>12}" + "".join(f"{v:7.1f}" for v in r))
    print(f"{'contact (N)':>12}" + "".join(f"{v:7.0f}" for v in contact))
    for name, r in rows.items():
        if name != "band (FEM)":
            print(f"band - {name}: RMS {np.sqrt(np.mean((np.array(band) - r) ** 2)):.1f} mm")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
