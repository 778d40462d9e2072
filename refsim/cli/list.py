"""`refsim list`: cases, engines (availability, version), benches and integrators."""
from __future__ import annotations

HELP = "cases, engines (availability, version) and integrators"


def add_arguments(parser) -> None:
    """No options."""


def main(args=None) -> int:
    return cmd_list()


def cmd_list() -> int:
    from refsim.registry import entries, get_case, get_engine
    from refsim.integrators import INTEGRATORS, PARAMETRISED, get_integrator

    print("cases:")
    for name, found in entries("case").items():
        case = get_case(name)
        print(f"  {name:18s} {case.description}")
        print(f"  {'':18s} variants: {', '.join(case.variants)}")
        print(f"  {'':18s} from: {found.origin} ({found.target})")
    print("engines:")
    for name, found in entries("engine").items():
        eng = get_engine(name)
        state = f"available {eng.version()}" if eng.available() else "unavailable"
        print(f"  {name:18s} {state:22s} integrators: {', '.join(eng.integrators)}")
        print(f"  {'':18s} from: {found.origin} ({found.target})")
    print("benches:")
    for name, found in entries("bench").items():
        print(f"  {name:18s} from: {found.origin} ({found.target})")
    print("integrators:")
    for name in INTEGRATORS:
        d = get_integrator(name).describe()
        kind = "explicit" if d["explicit"] else "implicit"
        extra = f"  [{PARAMETRISED[name]}]" if name in PARAMETRISED else ""
        print(f"  {name:20s} order {d['order']}  {kind:8s} {d['family']}"
              f"{' (symplectic)' if d['symplectic'] else ''}{extra}")
    return 0
