"""The humeral head of the MoBL-ARMS parent's humerus as a sphere, for the footprint sheets' contact surface
(shoulder_bench/authoring/fem/footprint.py HUMERAL_HEAD, docs/fem.md "Footprint sheets").

    pip download osim-rl==3.0.11 --no-deps -d /tmp && tar xzf /tmp/osim-rl-3.0.11.tar.gz -C /tmp
    python models/reference/scripts/humeral_head.py /tmp/osim-rl-3.0.11/osim/models/Geometry/humerus.vtp

humerus.vtp is the bone surface MoBL_ARMS_J.osim attaches to its `humerus` body (identity transform, scale 1), in
that body's frame (origin at the glenohumeral centre), metres. The fit: least-squares sphere (algebraic, then the
points' distances) through the mesh vertices within SELECT_M of the body origin (the head and the start of the neck),
refitted once through those of them within INLIER_M of the first sphere (dropping the tuberosities and the neck).
Prints the centre (m, humerus frame), the radius, the RMS residual and the vertex counts.
"""
from __future__ import annotations

import sys

import numpy as np

SELECT_M = 0.035
INLIER_M = 0.002


def vertices(path: str) -> np.ndarray:
    """The <Points> of an ASCII VTK PolyData file, (N, 3)."""
    text = open(path).read()
    block = text.split("<Points>")[1].split("</DataArray>")[0]
    return np.array(block.split(">", 1)[1].split(), float).reshape(-1, 3)


def sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    a = np.c_[2 * points, np.ones(len(points))]
    sol = np.linalg.lstsq(a, (points**2).sum(1), rcond=None)[0]
    return sol[:3], float(np.sqrt(sol[3] + sol[:3] @ sol[:3]))


def main(path: str) -> None:
    x = vertices(path)
    near = x[np.linalg.norm(x, axis=1) < SELECT_M]
    c, r = sphere(near)
    inliers = near[np.abs(np.linalg.norm(near - c, axis=1) - r) < INLIER_M]
    c, r = sphere(inliers)
    rms = float(np.sqrt(np.mean((np.linalg.norm(inliers - c, axis=1) - r) ** 2)))
    print(f"vertices {len(x)}, within {SELECT_M * 1e3:.0f} mm of the origin {len(near)}, inliers {len(inliers)}")
    print(f"centre {np.round(c, 5).tolist()} m, radius {r:.5f} m, RMS residual {rms * 1e3:.2f} mm")


if __name__ == "__main__":
    main(sys.argv[1])
