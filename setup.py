"""pincal's packages, found rather than listed: every ``pincal*`` package under ``pincal/`` (a new
subpackage ships without editing anything), and the URDFs of ``robots/`` as ``pincal.robots``.

``pyproject.toml`` holds everything else (metadata, ``package-dir`` mapping ``robots/`` to
``pincal.robots``, package data). The discovery lives here because ``[tool.setuptools.packages.find]``
cannot add a package that sits outside the folder it searches; tests/contracts/test_packaging.py checks the
built wheel against the source tree.
"""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["pincal", "pincal.*"]), "pincal.robots"])
