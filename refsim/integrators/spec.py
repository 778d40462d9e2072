"""An integrator as a user names it, parsed in one place: `name` or `name:parameter`
('rk4', 'rk2:0.5' with Ralston's alpha, 'dopri5_adaptive:1e-8' with rtol). Every module that
needs the method's name or its parameter asks here (`IntegratorSpec.parse`, `spec_name`);
what the parameter means and its valid range is the stepper's (refsim.integrators.PARAMETRISED).
No imports: engines, cases and the harness can all use it."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class IntegratorSpec:
    name: str  # the method's name: 'rk2' of 'rk2:0.5'
    arg: str = ""  # the text after ':' ('' when none)
    colon: bool = False  # a ':' was written (an empty parameter after it is an error)

    @classmethod
    def parse(cls, spec) -> IntegratorSpec:
        """The parts of a spec string (None: the engine's default, name '')."""
        name, colon, arg = ("" if spec is None else str(spec)).partition(":")
        return cls(name, arg, bool(colon))

    def number(self, what: str) -> float | None:
        """The parameter as a float (None when none is given); `what` names it and its range
        in the error."""
        if not self.arg:
            return None
        try:
            return float(self.arg)
        except ValueError:
            raise ValueError(f"integrator {self.name} parameter: {what}; got {self.arg!r}") \
                from None

    def __str__(self) -> str:
        return f"{self.name}:{self.arg}" if self.colon else self.name


def spec_name(spec) -> str:
    """The method's name of an integrator spec ('rk2:0.5' -> 'rk2'; None -> '')."""
    return IntegratorSpec.parse(spec).name
