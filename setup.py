"""Build of the optional C extension ``simgap.identifiers._call``; metadata is in pyproject.toml.

The extension only calls the identifier kernel without numba's dispatcher
(``simgap/identifiers/fastcall.py``). ``optional=True``: without a C compiler the build
prints a warning and simgap installs without it (the identifiers then use the dispatcher).
"""

import numpy
from setuptools import Extension, setup

setup(ext_modules=[Extension("simgap.identifiers._call", ["simgap/identifiers/_call.c"],
                             include_dirs=[numpy.get_include()], optional=True)])
