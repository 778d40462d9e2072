"""Model groups as files: a module in an engine package's groups/ takes the scenes it claims
(supports, formulations, build) with no edit to the engine, and scene parts of a kind the core
does not know travel in Scene.extra."""
from __future__ import annotations

import sys
import textwrap
from dataclasses import dataclass

import pytest

from refsim.engine import discover_groups
from refsim.scene import Body, Particles, Scene

ENGINE = '''
from refsim.engine import Engine, ModelGroup, Sim


class ToySim(Sim):
    def __init__(self, dt):
        self.dt = dt

    def _step_impl(self, n):
        pass

    def _observe(self):
        return {"x": [[0.0, 0.0, 0.0]], "v": [[0.0, 0.0, 0.0]]}


class ToyEngine(Engine):
    name = "toy_groups"
    integrators = ("symplectic_euler",)
    refusals = {"ropes": "toy_groups has no ropes (a toy engine: particles and beads only)"}
    groups = (ModelGroup(name="particles", claims=lambda scene: "particles" in scene.part_kinds(),
                         parts=frozenset({"particles"}), features=frozenset({"gravity"}),
                         build=lambda engine, scene, dt, integrator, formulation: ToySim(dt)),)
'''

GROUP = '''
from refsim.engine import ModelGroup

from ..engine import ToySim


class CountingSim(ToySim):
    built_by_group = True


MODEL_GROUP = ModelGroup(
    name="beads", claims=lambda scene: "beads" in scene.part_kinds(),
    parts=frozenset({"beads"}), features=frozenset({"bead_forces"}),
    integrators=("rk4",), formulations=lambda engine, scene: ("", "fast"),
    supports=lambda engine, scene, integrator: None,
    build=lambda engine, scene, dt, integrator, formulation: CountingSim(dt))
'''


@dataclass(frozen=True)
class Beads:
    count: int
    kind = "beads"
    moving = True

    def features(self):
        return {"bead_forces"}


@pytest.fixture
def toy_engine(tmp_path, monkeypatch):
    pkg = tmp_path / "toy_groups_pkg"
    (pkg / "groups").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "engine.py").write_text(textwrap.dedent(ENGINE))
    (pkg / "groups" / "__init__.py").write_text("")
    (pkg / "groups" / "beads.py").write_text(textwrap.dedent(GROUP))
    monkeypatch.syspath_prepend(str(tmp_path))
    from toy_groups_pkg.engine import ToyEngine
    yield ToyEngine()
    for name in [m for m in sys.modules if m.startswith("toy_groups_pkg")]:
        del sys.modules[name]


def test_group_module_is_discovered(toy_engine):
    groups = discover_groups(type(toy_engine))
    assert [g.name for g in groups] == ["beads"]
    assert groups[0].module == "toy_groups_pkg.groups.beads"


def test_claimed_scene_goes_to_the_group(toy_engine):
    scene = Scene(parts=(Beads(3),))
    assert scene.part_kinds() == {"beads"} and scene.features() == {"bead_forces"}
    assert toy_engine.supports(scene, "rk4") is None
    assert toy_engine.supports(scene, "symplectic_euler") == \
        "toy_groups offers no integrator 'symplectic_euler'"
    assert toy_engine.formulations(scene) == ("", "fast")
    assert getattr(toy_engine.build(scene, 0.1, "rk4", "fast"), "built_by_group", False)


def test_groups_declared_in_the_class_come_before_the_found_ones(toy_engine):
    scene = Scene(parts=(Particles.of((Body(1.0, (0, 0, 0)),)),), gravity=(0, 0, -9.81))
    assert [g.name for g in toy_engine.model_groups()] == ["particles", "beads"]
    assert toy_engine.group_for(scene).name == "particles"
    assert toy_engine.supports(scene, "symplectic_euler") is None
    assert toy_engine.formulations(scene) == ("",)
    sim = toy_engine.build(scene, 0.1, "symplectic_euler")
    assert not getattr(sim, "built_by_group", False)
    sim.step(3)
    assert sim.steps == 3 and sim.observe()["t"] == pytest.approx(0.3)


@dataclass(frozen=True)
class Ropes:
    kind = "ropes"
    moving = True

    def features(self):
        return set()


@dataclass(frozen=True)
class Knots:
    kind = "knots"
    moving = True

    def features(self):
        return {"tangles"}


def test_engine_refuses_from_its_table_a_scene_no_group_claims(toy_engine):
    scene = Scene(parts=(Ropes(),))
    assert toy_engine.group_for(scene) is None
    reason = "toy_groups has no ropes (a toy engine: particles and beads only)"
    assert toy_engine.supports(scene, "symplectic_euler") == reason
    with pytest.raises(ValueError, match=r"has no ropes \(a toy engine"):
        toy_engine.build(scene, 0.1, "symplectic_euler")
    # a kind outside the table: the generic sentence names the kinds and features
    assert toy_engine.supports(Scene(parts=(Knots(),), gravity=(0, 0, -1)), None) == \
        "toy_groups has no model group for a scene of knots with gravity, tangles"


def test_a_group_refuses_what_it_does_not_simulate(toy_engine):
    scene = Scene(parts=(Particles.of((Body(1.0, (0, 0, 0)),)),), linear_drag=0.5)
    assert toy_engine.supports(scene, "symplectic_euler") == "toy_groups does not simulate drag"


@pytest.mark.parametrize("bad, message", [
    (object(), "must hold parts (each with a `kind`)"),
    (type("NoFeatures", (), {"kind": "nofeat"})(), "must define features()"),
])
def test_a_plugin_part_is_validated(bad, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        Scene(parts=(bad,))


def test_a_plugin_part_counts_as_a_moving_kind():
    with pytest.raises(ValueError, match="one kind of moving bodies"):
        Scene(parts=(Particles.of((Body(1.0, (0, 0, 0)),)), Beads(2)))
    assert Scene(parts=(Beads(2),)).moving_kind() == "beads"
