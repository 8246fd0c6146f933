"""Default material data shipped with forming, each value with its source."""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Literal

from forming.errors import InputError
from forming.materials.curves import CompressionCurve
from forming.materials.elasticity import IsotropicElasticity, TransverselyIsotropicElasticity
from forming.materials.solids import CrushableFoam, ElasticSolid

DATA = resources.files("forming") / "data"


def core_data() -> dict:
    """The honeycomb core's data file, parsed (values with ``kind`` and ``source``)."""
    return tomllib.loads((DATA / "honeycomb_core.toml").read_text())


def _values(section: dict) -> dict:
    return {k: v["value"] for k, v in section.items()}


def honeycomb_core(
    elasticity: Literal["transverse", "isotropic"] = "transverse",
    plastic: bool = True,
    curve: str | Path | None = None,
    **overrides: float,
) -> CrushableFoam | ElasticSolid:
    """The macro-scale honeycomb core of the paper.

    Args:
        elasticity: ``"transverse"`` (matches all three measured moduli) or
            ``"isotropic"`` (parity with Abaqus's crushable foam).
        plastic: Crushable foam if True, else the elastic part only (no plastic state).
        curve: A CSV of the user's own C365 test (nominal strain, nominal stress MPa);
            default: the shipped estimate.
        **overrides: Replace any scalar of the data file (``E_through=12.0``, ``k=1.0``).

    Raises:
        InputError: Unknown override or invalid value (naming the field).
    """
    data = core_data()
    if elasticity not in ("transverse", "isotropic"):
        raise InputError("core.elasticity", f"must be 'transverse' or 'isotropic', got "
                         f"{elasticity!r}")
    el = _values(data[elasticity])
    foam = _values(data["foam"])
    measure = el.pop("strain_measure")
    known = set(el) | {"k", "kt", "strain_measure", "viscosity", "density", "elastic_band"}
    density = data["mass"]["density"]["value"]
    for key, val in overrides.items():
        if key not in known:
            raise InputError(f"core.{key}", f"unknown core parameter; known: {sorted(known)}")
        if key in el:
            el[key] = val
        elif key == "strain_measure":
            measure = val
        elif key == "density":
            density = val
        else:
            foam[key] = val
    law = (TransverselyIsotropicElasticity(**el) if elasticity == "transverse"
           else IsotropicElasticity(**el))
    if not plastic:
        return ElasticSolid(law, strain_measure=measure, density=density)
    path = Path(curve) if curve is not None else Path(str(DATA / foam["curve"]))
    return CrushableFoam(law, CompressionCurve.from_csv(path), k=foam["k"], kt=foam["kt"],
                         strain_measure=measure, viscosity=foam.get("viscosity", 0.0),
                         density=density, elastic_band=foam.get("elastic_band", 0.05))
