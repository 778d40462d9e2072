"""Helpers shared by the engine tests are imported by basename from tests/engines/common and from
tests/conformance (the scenes, cases and reference replicas of the model groups several engines
run, with the conformance tests that check them on each engine)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "common"))
sys.path.insert(0, str(Path(__file__).parents[1] / "conformance"))
