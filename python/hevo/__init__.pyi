"""Type stubs of the hevo package: everything comes from hevo._hevo."""

from ._hevo import *  # noqa: F401,F403
from ._hevo import __version__ as __version__
