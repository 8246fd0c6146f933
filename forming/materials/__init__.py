"""Materials: elasticity, tabulated curves and quadrature-point solids."""

from forming.materials.curves import CompressionCurve
from forming.materials.elasticity import IsotropicElasticity, TransverselyIsotropicElasticity
from forming.materials.solids import CrushableFoam, ElasticSolid, evaluate

__all__ = [
    "CompressionCurve",
    "CrushableFoam",
    "ElasticSolid",
    "IsotropicElasticity",
    "TransverselyIsotropicElasticity",
    "evaluate",
]
