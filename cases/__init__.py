"""Canonical scenarios, one module each, grouped by model group; each module holds a `CASE`
declared under the `refsim.cases` entry points in pyproject.toml (refsim/registry.py)."""
