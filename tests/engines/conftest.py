"""Shared helpers of the engine tests live in tests/engines/common (imported by basename)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "common"))
