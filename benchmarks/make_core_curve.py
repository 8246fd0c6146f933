"""Regenerate forming/data/core_c365_estimate.csv, the estimated C365 curve.

The shape follows the paper's text (linear region, peak, long plateau, densification
from 0.75 strain, about 4 MPa at 0.90); the magnitudes are the labelled estimates of
docs/materials.md. Run: python benchmarks/make_core_curve.py > forming/data/core_c365_estimate.csv
"""

import numpy as np


def curve() -> list[tuple[float, float]]:
    pts = [(0.0, 0.0), (0.02, 0.30)]  # linear region, E = 15 MPa
    for e in np.linspace(0.0225, 0.035, 6):  # hardening to the 0.40 MPa peak
        x = (e - 0.02) / 0.015
        pts.append((e, 0.30 + 0.10 * (2 * x - x * x)))
    for e in np.linspace(0.0375, 0.055, 8):  # buckling: drop to the plateau
        x = (e - 0.035) / 0.02
        pts.append((e, 0.25 + 0.15 * 0.5 * (1 + np.cos(np.pi * x))))
    for e in np.linspace(0.1, 0.6, 6):  # plateau
        pts.append((e, 0.25))
    for e in np.linspace(0.625, 0.75, 6):  # end of plateau
        pts.append((e, 0.25 + 0.10 * ((e - 0.6) / 0.15) ** 2))
    for e in np.linspace(0.76, 0.90, 15):  # densification
        pts.append((e, 0.35 + 3.65 * ((e - 0.75) / 0.15) ** 4.25))
    return pts


if __name__ == "__main__":
    print("# Estimated C365 nominal curve of the cardboard honeycomb (docs/materials.md)")
    print("nominal_strain,nominal_stress_MPa")
    for e, s in curve():
        print(f"{e:.4f},{s:.4f}")
