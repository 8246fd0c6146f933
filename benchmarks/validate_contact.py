"""Contact verification figures for docs/validation.md: Hertz refinement, sled, flat punch.

Run: ``python benchmarks/validate_contact.py`` (about 3 minutes).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from _report import REPO, update_section  # noqa: E402
from test_contact import _hertz, _sled  # noqa: E402


def main() -> None:
    lines = ["## Contact verification", "",
             "Rigid sphere (R = 200 mm) on an elastic block (E = 100 MPa, nu = 0.3), quarter "
             "model, indentation to 0.0625 mm (contact radius 3.5 mm); the fitted coefficient "
             "of F = C d^1.5 against Hertz's 4/3 E* sqrt(R):", "",
             "| block [mm] | cells | smallest cell [mm] | C / C_Hertz | wall [s] |",
             "|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ratios = {}
        for L, n, g in ((50.0, 12, 1.25), (50.0, 16, 1.18), (400.0, 14, 1.45),
                        (400.0, 18, 1.35)):
            t0 = time.perf_counter()
            _s, ratio, _h = _hertz(tmp / f"h{L}_{n}", (n, n, n), (g, g, 1 / g), L=L)
            ratios[(L, n)] = ratio
            h0 = L * (g - 1) / (g**n - 1)
            lines.append(f"| {L:.0f} | {n}^3 | {h0:.2f} | {ratio:.4f} "
                         f"| {time.perf_counter() - t0:.0f} |")
        lines += ["", "A rigid base at depth H stiffens the response by O(a/H): the 50 mm block "
                  f"stays {ratios[(50.0, 16)] - 1:.1%} above Hertz under refinement, the "
                  f"400 mm block goes from {ratios[(400.0, 14)] - 1:.1%} to "
                  f"{ratios[(400.0, 18)] - 1:.1%}.",
                  "",
                  "Friction sled (core block 100 x 50 x 20 mm, 2 kPa, table dragged 5 mm):", "",
                  "| mu | force ratio (all sliding steps) | normal force [N] |", "|---|---|---|"]
        for mu in (0.36, 0.52, 0.57):
            _s, h = _sled(tmp / f"sled{mu}", mu, drag=True)
            ratio = np.abs(h["force_table_x_N"][1:] / h["force_table_z_N"][1:])
            lines.append(f"| {mu} | {ratio.min():.6f} to {ratio.max():.6f} "
                         f"| {-h['force_table_z_N'][-1]:.4f} |")
        _s, h = _sled(tmp / "stick", 0.36, drag=False, tolerance=1e-5)
        lines += ["", f"Below the limit (shear load 0.5 mu p): sled slip "
                  f"{h['sole_slip_mean_mm'].max():.1e} mm (mean over the sole), largest nodal "
                  f"slip {h['sole_slip_max_mm'].max():.1e} mm at the unloaded trailing edge."]
    update_section("contact", "\n".join(lines), REPO / "docs" / "validation.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
