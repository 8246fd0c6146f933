"""The meso scale: honeycomb cell walls modelled one by one (issue 20)."""
