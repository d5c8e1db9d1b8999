"""What pyproject.toml cannot say: the package list. ``find_packages`` over ``mitsar/`` plus the
data packages that live at the top level of the checkout and install inside ``mitsar``
(``[tool.setuptools.package-dir]`` in pyproject.toml maps them; docs/decisions.md, "Layout")."""

from setuptools import find_packages, setup

DATA_PACKAGES = ["mitsar._examples", "mitsar._scenes"]
"""Top-level folders installed as sub-packages of mitsar (pyproject.toml's package-dir)."""

setup(packages=find_packages(include=["mitsar", "mitsar.*"]) + DATA_PACKAGES)
