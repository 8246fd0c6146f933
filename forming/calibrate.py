"""Meso to macro: the macro core's C365 curve from a meso-scale compression run.

``forming calibrate meso_compression --out DIR [--set ...] [--no-moduli]`` runs the meso
case (its cell walls modelled) into ``DIR/meso``, turns its nominal stress-strain curve
into the curve the macro core reads (:meth:`CompressionCurve.from_csv`), and checks it:
the macro ``core_compression`` run with that curve and the meso run's initial modulus, in
``DIR/check``, must reproduce it (its ``curve_rmse_rel``). Written into ``DIR``:

* ``c365_meso.csv``: the curve, with its provenance in ``#`` lines;
* ``calibration.json``: the through-thickness modulus; the transverse shear moduli
  along x (ribbon) and y from two shear runs of the same patch (``DIR/shear_x``,
  ``DIR/shear_y``); the in-plane moduli and Poisson ratios along x and y from two
  in-plane tension runs (``DIR/tension_x``, ``DIR/tension_y``; on the same cells, at
  least 2 x 3 of them: :mod:`forming.meso.inplane`); ``--no-moduli`` skips those four
  runs; where and why the curve was cut, the check's error, and the command that uses
  the curve with the moduli the macro core takes;
* ``calibration.png``: the meso curve, the shipped macro curve and the calibrated macro
  run on one plot.

Only the part of a meso run the macro crushable foam can represent is kept
(:func:`representable`): the curve ends before a point where it rises faster than the
elastic line (its plastic strain would decrease), and points closer than
:data:`MIN_SPACING` in strain are merged. A fall, however steep (walls breaking), is
plastic straining and is kept. Before the walls buckle the curve is put on the macro
core's elastic line (:func:`straighten`), so that the foam's yield is where they buckle.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
from mpi4py import MPI

from forming.errors import InputError
from forming.materials.curves import CompressionCurve

log = logging.getLogger(__name__)

MIN_SPACING = 1e-4  # smallest strain between two kept points of the curve
BAND = 0.005  # a meso point within this fraction of the elastic line is on it
CURVE_FILE = "c365_curve.csv"  # what meso_compression writes into its folder
CASES = ("meso_compression",)


def elastic_line(strain: np.ndarray, modulus: float) -> np.ndarray:
    """Nominal stress of the macro core's elastic line (its strain measure) at ``strain``."""
    from forming.materials.kernels import strain_f, strain_theta
    from forming.materials.library import honeycomb_core
    from forming.materials.solids import measure_code

    m = measure_code(honeycomb_core("transverse", plastic=False).strain_measure)
    lam = 1.0 - np.asarray(strain, dtype=float)
    c = lam**2
    e_tot = np.array([strain_f(ci, m) for ci in c])
    kappa = np.array([2 * ci * strain_theta(ci, ci, m) for ci in c]) / lam
    return -kappa * modulus * e_tot


def straighten(strain: np.ndarray, stress: np.ndarray, modulus: float
               ) -> tuple[np.ndarray, int]:
    """The curve put on the elastic line up to the onset of the walls' buckling.

    Points before the first that falls :data:`BAND` below the elastic line are moved onto
    it; returns the curve and that point's index. Before the walls buckle, the meso
    curve and the macro core's elastic line differ by a few tenths of a per cent (the
    walls' Poisson restraint at the platens, the measures); after it the curve is the
    meso run's.
    """
    line = elastic_line(strain, modulus)
    below = np.nonzero(stress[1:] < (1.0 - BAND) * line[1:])[0]
    onset = int(below[0]) + 1 if below.size else len(strain)
    out = np.asarray(stress, dtype=float).copy()
    out[:onset] = line[:onset]
    return out, onset


def representable(strain: np.ndarray, stress: np.ndarray, modulus: float
                  ) -> tuple[np.ndarray, np.ndarray, str]:
    """The longest leading part of a nominal curve that the macro core can follow.

    Points closer than :data:`MIN_SPACING` in strain are merged; then the curve is cut
    before the first point the crushable foam of ``modulus`` refuses (the checks of
    :attr:`CrushableFoam.hardening`: a rise steeper than the elastic line, a point
    above it).

    Returns:
        (strain, stress, the foam's reason for the cut: ``""`` if the curve was kept whole).
    """
    keep = [0]
    for i in range(1, len(strain)):
        if strain[i] - strain[keep[-1]] >= MIN_SPACING:
            keep.append(i)
    e, s = np.asarray(strain)[keep], np.asarray(stress)[keep]
    foam = _foam_with(modulus)
    first_error = ""
    for n in range(e.size, 2, -1):
        try:
            _ = foam(e[:n], s[:n]).hardening
        except InputError as err:
            first_error = first_error or str(err)
            continue
        why = f"cut after strain {e[n - 1]:.4g}: {first_error}" if first_error else ""
        return e[:n], s[:n], why
    return e[:2], s[:2], f"cut after strain {e[1]:.4g}: {first_error}"


def _foam_with(modulus: float):
    """The macro core (shipped data, this through-thickness modulus) for a given curve."""
    from forming.materials.library import core_data, honeycomb_core
    from forming.materials.solids import CrushableFoam

    elastic = honeycomb_core("transverse", plastic=False, E_through=modulus)
    data = core_data()["foam"]

    def foam(strain: np.ndarray, stress: np.ndarray) -> CrushableFoam:
        return CrushableFoam(elastic.elasticity,
                             CompressionCurve(tuple(strain), tuple(stress), "meso"),
                             k=data["k"]["value"], kt=data["kt"]["value"],
                             strain_measure=elastic.strain_measure, elastic_band=BAND)

    return foam


SHEAR_STRAIN = 0.005  # nominal shear strain of the shear runs (elastic walls' range)
TENSION_STRAIN = 0.002  # nominal strain of the in-plane tension runs (elastic walls)


def tension_assignments(case: str, assignments: list[str], load: str) -> list[str]:
    """The settings of an in-plane tension run of the patch ``assignments`` describe.

    The same walls and cells, at least 2 x 3 cells (the lattice measures need inner rows
    of ribbon walls, :func:`forming.meso.inplane.check_patch`), the walls alone
    (``variant=original``), one load step to :data:`TENSION_STRAIN`, and the case's
    default stabilisation if the patch's is off (it holds the free rigid motion).

    Raises:
        InputError: ``assignments`` are not the case's (read as the case reads them).
    """
    from forming.case import load_case, parse_params, split_solver_settings

    params_cls = load_case(case).Params
    p = parse_params(params_cls, split_solver_settings(assignments)[2])
    nx, ny = p.cells
    extra = [f"load={load}", f"strain={TENSION_STRAIN!r}", "max_step=1.0", "buckling=false",
             "variant=original", f"cells={max(nx, 2)},{max(ny, 3)}"]
    if p.stabilisation <= 0.0:
        extra.append(f"stabilisation={params_cls().stabilisation!r}")
    return [*assignments, *extra]


def moduli(case: str, out: Path, assignments: list[str]) -> dict:
    """Transverse shear and in-plane moduli of the patch, four elastic runs (collective).

    Shear along x (the ribbon) and y (``load=shear_x|shear_y`` to :data:`SHEAR_STRAIN`,
    in ``out/shear_x|shear_y``): ``G_through``. In-plane tension along x and y
    (:func:`tension_assignments`, in ``out/tension_x|tension_y``): the lattice's moduli
    and Poisson ratios, and their means, what the macro core's transversely isotropic
    law takes (``E_inplane``, ``nu_inplane``).
    """
    from forming.case import run_case

    found: dict[str, float | None] = {}
    for load in ("shear_x", "shear_y"):
        run = run_case(case, out / load, [*assignments, f"load={load}",
                                          f"strain={SHEAR_STRAIN!r}", "max_step=0.5",
                                          "buckling=false"])
        found[f"shear_modulus_{load[-1]}z_MPa"] = run.get("metrics", {}).get(
            "shear_modulus_MPa")
    for load in ("tension_x", "tension_y"):
        run = run_case(case, out / load, tension_assignments(case, assignments, load))
        m = run.get("metrics", {})
        found[f"inplane_modulus_{load[-1]}_MPa"] = m.get("inplane_modulus_MPa")
        found[f"inplane_poisson_{load[-1]}"] = m.get("inplane_poisson")
        found[f"gibson_ashby_inplane_{load[-1]}_MPa"] = m.get("gibson_ashby_inplane_MPa")
        found["tension_cells"] = ",".join(str(c) for c in run["parameters"]["cells"])
    pairs = [(found["inplane_modulus_x_MPa"], found["inplane_modulus_y_MPa"]),
             (found["inplane_poisson_x"], found["inplane_poisson_y"])]
    means = [0.5 * (a + b) if a is not None and b is not None else None for a, b in pairs]
    return found | {"E_inplane_MPa": means[0], "nu_inplane": means[1]}


def core_overrides(modulus: float, found: dict) -> dict[str, float]:
    """The calibrated moduli as keyword arguments of ``honeycomb_core``.

    With ``curve=`` the calibrated curve, they make
    :func:`~forming.materials.library.honeycomb_core` the calibrated core. ``E_through``
    is the meso run's modulus; ``G_through`` the mean of the two shear moduli,
    ``E_inplane`` that of the two tension moduli, where they were run. The in-plane
    Poisson ratio is given only if the transversely isotropic law can take it (below 1):
    a bending-dominated regular hexagonal lattice has 1 (Gibson and Ashby).
    """
    out = {"E_through": modulus}
    shear = [found.get(f"shear_modulus_{a}z_MPa") for a in "xy"]
    if all(g is not None for g in shear):
        out["G_through"] = 0.5 * (shear[0] + shear[1])
    if found.get("E_inplane_MPa") is not None:
        out["E_inplane"] = found["E_inplane_MPa"]
    nu = found.get("nu_inplane")
    if nu is not None and -1.0 < nu < 1.0:
        out["nu_inplane"] = nu
    return out


def calibrate(case: str, out: Path, assignments: list[str], with_moduli: bool = True
              ) -> dict:
    """Run the meso case, write the macro curve and check it (collective).

    With ``with_moduli``, :func:`moduli` also runs the patch in transverse shear and
    in-plane tension: the macro core's other moduli.

    Raises:
        InputError: ``case`` is not a meso case, or its run gave too short a curve.
    """
    from forming.case import run_case

    if case not in CASES:
        raise InputError("calibrate", f"calibrates from a meso case ({', '.join(CASES)}), "
                         f"not {case!r}")
    comm = MPI.COMM_WORLD
    out = Path(out)
    meso = run_case(case, out / "meso", assignments)
    raw = CompressionCurve.from_csv(out / "meso" / CURVE_FILE)
    e_raw, s_raw = np.asarray(raw.strain), np.asarray(raw.stress)
    modulus = float(s_raw[1] / elastic_line(e_raw[1:2], 1.0)[0])
    s_straight, onset = straighten(e_raw, s_raw, modulus)
    e, s, cut = representable(e_raw, s_straight, modulus)
    if e.size < 3:
        raise InputError("calibrate", f"the meso run ({meso['status']}) gave {e.size} usable "
                         "points; the macro curve needs 3 or more")
    if meso["status"] != "completed":
        cut = cut or f"the meso run {meso['status']}: {meso.get('reason', '')}"
    curve_path = out / "c365_meso.csv"
    if comm.rank == 0:
        CompressionCurve(tuple(e), tuple(s), str(curve_path)).to_csv(
            curve_path, f"C365 nominal curve from forming calibrate {case} "
            f"({' '.join('--set ' + a for a in assignments) or 'defaults'}); meso run "
            f"{meso['status']} at strain {e_raw[-1]:.4g}; initial modulus {modulus:.6g} MPa")
    comm.barrier()
    sets = [f"curve={curve_path}", f"modulus={modulus!r}", f"strain={float(e[-1])!r}",
            f"elastic_band={BAND!r}"]
    check = run_case("core_compression", out / "check", sets)
    macro = _macro_curve(out / "check")
    n = e.size
    against_meso = float(np.sqrt(np.mean((np.interp(e_raw[:n], *macro) - s_raw[:n]) ** 2))
                         / np.sqrt(np.mean(s_raw[:n] ** 2)))
    found = moduli(case, out, assignments) if with_moduli else {}
    result = {
        "case": case, "assignments": assignments, **found,
        "meso_status": meso["status"], "meso_strain_reached": float(e_raw[-1]),
        "curve": str(curve_path), "points": int(e.size), "strain_end": float(e[-1]),
        "cut": cut or None, "modulus_MPa": modulus,
        "buckling_onset_strain": float(e_raw[min(onset, e_raw.size - 1)]),
        "largest_change_before_onset_rel": float(np.max(np.abs(
            s_straight[1:onset] / s_raw[1:onset] - 1.0), initial=0.0)),
        "check_status": check["status"],
        "check_rmse_rel": check.get("metrics", {}).get("curve_rmse_rel"),
        "macro_against_meso_rmse_rel": against_meso,
        "use": "forming run core_compression " + " ".join(f"--set {x}" for x in sets),
        "core_overrides": core_overrides(modulus, found),
    }
    if comm.rank == 0:
        (out / "calibration.json").write_text(json.dumps(result, indent=2) + "\n")
        _plot(out, e_raw, s_raw, macro)
        log.info("calibrated curve %s: %d points to strain %.4g, modulus %.4g MPa, macro "
                 "check %s (relative RMS %.3g)", curve_path, e.size, e[-1], modulus,
                 check["status"], result["check_rmse_rel"] or float("nan"))
    return result


def _macro_curve(check: Path) -> tuple[np.ndarray, np.ndarray]:
    """Nominal strain and stress of a ``core_compression`` run."""
    h = np.genfromtxt(check / "history.csv", delimiter=",", names=True)
    p = json.loads((check / "summary.json").read_text())["parameters"]
    return h["t"] * p["strain"], -h["reaction_top_z_N"] / p["width"] ** 2


def _plot(out: Path, e_meso: np.ndarray, s_meso: np.ndarray,
          macro: tuple[np.ndarray, np.ndarray]) -> Path:
    """Meso curve, shipped macro curve and the calibrated macro run, on one plot."""
    from forming.materials.library import honeycomb_core
    from forming.output import plot_curves

    grid = np.linspace(0.0, float(e_meso[-1]), 200)
    shipped = honeycomb_core("isotropic").curve
    return plot_curves(out / "calibration.png", [
        (e_meso, s_meso, "meso run (cell walls)", "o-"),
        (grid, shipped.interpolate(grid), "shipped macro curve (estimate of Fig. 6)", "k:"),
        (*macro, "macro core_compression with the calibrated curve", "x--"),
    ], "nominal strain", "nominal stress [MPa]", "Meso to macro: C365 curve")
