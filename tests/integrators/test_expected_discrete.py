"""refsim.expected's closed-form step matrices, written from each method's definition, predict
what refsim's own steppers do on a linear system: two independent derivations of the same
discrete solution must agree to round-off."""
import numpy as np
import pytest

from refsim.expected import discrete_solution, has_discrete_solution
from refsim.integrators import INTEGRATORS, get_integrator
from refsim.models.system import LinearSystem

FIXED = [name for name in INTEGRATORS if has_discrete_solution(name)] + ["rk2:0.5"]
STEPS = [0, 1, 7, 40]
# two-dof system with coupling; damped and undamped
K = np.array([[40.0, -12.0], [-12.0, 25.0]])
C = np.array([[0.6, 0.1], [0.1, 0.3]])


def run_stepper(spec, damping, h, n):
    stepper = get_integrator(spec)
    system = LinearSystem(K, damping)
    x0, v0 = np.array([0.3, -0.2]), np.array([0.5, 1.1])
    state = stepper.start(system, 0.0, x0, v0, h)
    out, t, done = [], 0.0, 0
    for k in STEPS:
        t, state = stepper.advance(system, t, state, h, k - done)
        done = k
        out.append(np.concatenate(stepper.output(system, t, state, h)))
    return np.array(out), x0, v0


@pytest.mark.parametrize("damped", [False, True])
@pytest.mark.parametrize("spec", FIXED)
def test_closed_form_equals_the_stepper(spec, damped):
    damping = C if damped else None
    h = 0.05
    ran, x0, v0 = run_stepper(spec, damping, h, STEPS[-1])
    x, v = discrete_solution(spec, -K, None if damping is None else -damping, x0, v0, h, STEPS)
    predicted = np.hstack([x, v])
    # round-off: 40 steps, each rounding a state of size ~1 to a few eps, amplified at most by
    # the step matrix's norm (< 2 at h = 0.05); 1e-12 leaves a factor ~50 over that
    assert np.max(np.abs(predicted - ran)) < 1e-12, spec


def test_adaptive_has_no_discrete_solution():
    assert not has_discrete_solution("dopri5_adaptive:1e-9")
    assert has_discrete_solution("rk2:0.5")


def test_integrator_specs_are_parsed_in_one_place():
    """IntegratorSpec: the name, the parameter text and whether a ':' was written; a bad
    number names the parameter's meaning."""
    from refsim.integrators.spec import IntegratorSpec, spec_name
    assert IntegratorSpec.parse("rk2:0.5") == IntegratorSpec("rk2", "0.5", True)
    assert IntegratorSpec.parse("rk4").number("none") is None
    assert spec_name("dopri5_adaptive:1e-8") == "dopri5_adaptive" and spec_name(None) == ""
    assert str(IntegratorSpec.parse("rk2:")) == "rk2:" and IntegratorSpec.parse("rk2:").colon
    with pytest.raises(ValueError, match="alpha in"):
        IntegratorSpec.parse("rk2:x").number("alpha in (0, 1]")
