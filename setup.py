"""Packages and where they live: the folders adapters/, cases/ and benchmarks/ (the repository's
layout) install as refsim_adapters, refsim_cases and refsim_benchmarks, so that installing refsim
adds no generic top-level names (`adapters`, `cases`, `benchmarks`) to site-packages. Everything
else is in pyproject.toml."""
from setuptools import find_packages, setup

FOLDERS = {"refsim": "refsim", "refsim_adapters": "adapters", "refsim_cases": "cases",
           "refsim_benchmarks": "benchmarks"}
packages = [sub for name, folder in FOLDERS.items()
            for sub in [name] + [f"{name}.{p}" for p in find_packages(folder)]]
setup(packages=packages, package_dir=FOLDERS,
      package_data={"refsim_cases": ["data/*.csv"]})
