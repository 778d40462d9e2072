"""A third-party engine and case, in their own installed distribution, appear in `refsim
list`, run in `refsim run` and in `engine_suite` with no change to refsim.

The distribution is built from a pyproject in a temporary directory and pip-installed with
`--target` (a real install: wheel built, entry points written to its .dist-info), then put on
PYTHONPATH of subprocesses, so the test venv itself is never modified.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

PYPROJECT = """
[build-system]
requires = ["setuptools>=64"]
build-backend = "setuptools.build_meta"

[project]
name = "refsim-toyplugin"
version = "0.3.1"

[project.entry-points."refsim.engines"]
toy_euler = "toyplugin:ToyEngine"

[project.entry-points."refsim.cases"]
toy_drag = "toyplugin:CASE"
"""

MODULE = '''
"""A point mass with linear drag: semi-implicit Euler engine and its exact case."""
import math

import numpy as np

from refsim.case import Case, Param
from refsim.engine import Engine, IntegratorInfo, ModelGroup, Sim
from refsim.scene import Body, Particles, Scene


class ToySim(Sim):
    def __init__(self, scene, dt):
        self.dt, self.steps = dt, 0
        bodies = scene.part(Particles)
        self.m, self.b = bodies.mass[:, None], scene.linear_drag
        self.x, self.v = bodies.position.copy(), bodies.velocity.copy()

    def _step_impl(self, n):
        for _ in range(n):
            self.v = self.v - self.dt * self.b / self.m * self.v
            self.x = self.x + self.dt * self.v

    def _observe(self):
        return {"x": self.x.copy(), "v": self.v.copy()}

    def settings(self):
        return {"integrator": IntegratorInfo("symplectic_euler", 1, True)}


class ToyEngine(Engine):
    name = "toy_euler"
    dims, integrators = (3,), ("symplectic_euler",)
    groups = (ModelGroup(name="particles", claims=lambda scene: "particles" in scene.part_kinds(),
                         parts=frozenset({"particles"}), features=frozenset({"drag"}),
                         build=lambda engine, scene, dt, integrator, formulation:
                         ToySim(scene, dt)),)


class DragCase(Case):
    name = "toy_drag"
    description = "one particle slowed by linear drag; closed form"
    observable, units = "position", "m"
    params = {"mass": Param(1.0, 0.0, 1e3, "kg", low_inclusive=False),
              "drag": Param(0.5, 0.0, 1e3, "N s/m", low_inclusive=False),
              "v0": Param(2.0, -1e3, 1e3, "m/s")}

    def scene(self, p):
        return Scene(parts=(Particles.of((Body(mass=p["mass"], position=(0, 0, 0),
                                               velocity=(p["v0"], 0, 0)),)),),
                     linear_drag=p["drag"])

    def t_end(self, p):
        return 4.0

    def dts(self, p):
        return [0.01, 0.005]

    def reference_dt(self, p):
        return 0.005

    def observables(self, p, obs):
        return {"position": obs["x"][:, 0, 0]}

    def reference(self, p, t):
        k = p["drag"] / p["mass"]
        return {"position": p["v0"] / k * (1 - np.exp(-k * np.asarray(t)))}

    def motion_scale(self, p):
        return abs(p["v0"]) * p["mass"] / p["drag"]

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        k = p["drag"] / p["mass"]
        return (abs(p["v0"]) * self.t_end(p) * (k * dt) ** order,
                "first-order step: per-step velocity error <= (k dt)^2 v0 / 2, summed over "
                "t/dt steps and integrated: <= v0 t (k dt)^p")


CASE = DragCase()
'''

SUITE = """
from refsim.testing import engine_suite
test_toy_euler = engine_suite("toy_euler")
"""


@pytest.fixture(scope="module")
def plugin_env(tmp_path_factory):
    root = tmp_path_factory.mktemp("plugin")
    src, site = root / "src", root / "site"
    src.mkdir()
    (src / "pyproject.toml").write_text(PYPROJECT)
    (src / "toyplugin.py").write_text(textwrap.dedent(MODULE))
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
         "--target", str(site), str(src)], capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stderr[-2000:]
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site), str(Path.cwd())])
    return root, env


def _refsim(env, *args, cwd=None):
    return subprocess.run([sys.executable, "-m", "refsim", *args], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


def test_installed_plugin_is_listed_with_its_origin(plugin_env):
    _, env = plugin_env
    out = _refsim(env, "list")
    assert out.returncode == 0, out.stderr
    assert "toy_euler" in out.stdout and "toy_drag" in out.stdout
    assert "refsim-toyplugin 0.3.1 (toyplugin:ToyEngine)" in out.stdout
    assert "refsim-toyplugin 0.3.1 (toyplugin:CASE)" in out.stdout


def test_installed_plugin_runs_in_the_matrix_beside_refsim(plugin_env):
    root, env = plugin_env
    out = _refsim(env, "run", "--case", "toy_drag", "--engine", "toy_euler", "--engine",
                  "refsim", "--integrator", "symplectic_euler", "--out", str(root / "runs"),
                  "--no-report", "--jobs", "1", "--repeats", "1")
    assert out.returncode == 0, out.stderr[-2000:]
    run_dir = Path(out.stdout.strip().splitlines()[-1])
    table = pd.read_csv(run_dir / "results.csv")
    assert set(table["engine"]) == {"toy_euler", "refsim"}
    assert (table["status"] == "ok").all() and (table["consistency"] == "consistent").all()
    # the two engines implement the same step: the same errors to round-off
    by_engine = table.pivot_table(index="dt", columns="engine", values="err_max")
    assert (abs(by_engine["toy_euler"] - by_engine["refsim"]) <= 1e-12).all()
    stored = json.loads((run_dir / "cases.json").read_text())
    assert [d["case"] for d in stored] == ["toy_drag"]


def test_installed_plugin_engine_suite_passes(plugin_env, tmp_path):
    _, env = plugin_env
    (tmp_path / "test_toy_suite.py").write_text(SUITE)
    out = subprocess.run([sys.executable, "-m", "pytest", "-v", "-p", "no:cacheprovider",
                          str(tmp_path / "test_toy_suite.py")], capture_output=True,
                         text=True, env=env, cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stdout[-3000:]
    # the plugin's own case ran as a job of the suite, and it passed
    assert "test_toy_euler[toy_drag/default-symplectic_euler] PASSED" in out.stdout, \
        out.stdout[-3000:]
    assert " FAILED" not in out.stdout and " ERROR" not in out.stdout
