"""forming: process simulation of press-formed composite sandwich panels."""

try:  # PyPI wheels: PETSc/MPI libraries must load before any ``dolfinx`` import
    import dolfinx_solver  # noqa: F401
except ImportError:  # conda / Docker DOLFINx 0.11: nothing to preload
    pass

from forming import kernelcache  # noqa: E402

kernelcache.configure()  # before any kernel: numba's cache of this version of the sources

__version__ = "0.1.0"
