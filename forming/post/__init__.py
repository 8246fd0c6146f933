"""Post-processing shared by the cases: fields, named measurements, pictures and plots.

- :mod:`forming.post.fields`: the plastic strain as a field, with its integrals;
- :mod:`forming.post.metrics`: named, collective measurements (crushing depth, edge
  lift and draw-in, skin shear statistics, nodal gaps, whole-part figures);
- :mod:`forming.post.pictures`: sections and 3D views gathered on rank 0;
- :mod:`forming.post.plots`: plots of the history.
"""

from forming.post.fields import PlasticStrainField, plastic_field
from forming.post.metrics import (
    InternalPower,
    cell_mean_near,
    contact_metrics,
    crushed_volume,
    crushed_volume_probe,
    crushing_depth,
    edge_draw_in,
    edge_lift,
    force_mean,
    force_peak_final,
    hemisphere_metrics,
    interface_slip_at,
    interface_slips,
    nodal_gap_max,
    plastic_strain_extremes,
    plastic_strain_max,
    relative_rms,
    skin_shear_statistics,
    whole,
)
from forming.post.pictures import (
    deformed_grid,
    plastic_strain_pictures,
    section_polygons,
    shear_angle_picture,
)
from forming.post.plots import force_travel_plot, punch_force_plot

__all__ = [
    "InternalPower", "PlasticStrainField", "cell_mean_near", "contact_metrics",
    "crushed_volume", "crushed_volume_probe", "crushing_depth", "deformed_grid", "edge_draw_in",
    "edge_lift", "force_mean", "force_peak_final", "force_travel_plot", "hemisphere_metrics",
    "interface_slip_at", "interface_slips", "nodal_gap_max", "plastic_field",
    "plastic_strain_extremes", "plastic_strain_max", "plastic_strain_pictures",
    "punch_force_plot", "relative_rms", "section_polygons", "shear_angle_picture",
    "skin_shear_statistics", "whole",
]
