"""Solvers and the step lifecycle they share."""
