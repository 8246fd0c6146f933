"""The demonstrator: a doubly curved sandwich component formed between matched tools.

:mod:`~forming.demonstrator.geometry` defines the shipped component (our own design in
the spirit of the paper's, whose geometry is not published): its tool surfaces, the
cavity's core-thickness map and the trim line. :mod:`~forming.demonstrator.tools` builds
the matched tools as OpenCASCADE solids and writes them as STEP and STL.
"""
