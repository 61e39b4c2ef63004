"""optinav: inertial sensor calibration and attitude estimation posed as optimization problems.

Layout: ``optinav.core`` is the shared core (rotations, Earth model, IMU error models, simulation,
strapdown, alignment, optimizers, observability); one subpackage per published system is built on it;
``optinav.cli`` and ``optinav.reports`` sit on top. Conventions: docs/conventions.md.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("optinav")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+local"

from optinav.errors import OptinavError

__all__ = ["OptinavError", "__version__"]
