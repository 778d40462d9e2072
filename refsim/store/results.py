"""Saves each run as a directory (results.csv + manifest.json), atomically; loads runs back.

A run directory is never overwritten by another run: run ids carry a timestamp and a random
suffix. Within a run, every finished row is written at once (write to a temporary file, then
rename), so an interrupted run keeps all finished rows and can be resumed.
"""
from __future__ import annotations

import json
import os
import platform
import secrets
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd

from refsim.store.atomic import atomic_write  # noqa: F401  (the store's one writer)

DEFAULT_ROOT = Path("reports") / "runs"
JOURNAL = "rows.jsonl"
SERIES = "series.jsonl"
DEFINITIONS = "cases.json"  # each case x variant x parameters as run (Case.definition)
KEY = ["case", "variant", "engine", "engine_variant", "integrator", "dt"]
# The stored run's format, stamped in manifest.json ("format"). 2: the two verdicts
# (consistency, reaches_target) and call_us. A run without a stamp is format 1: stored before
# formats were stamped; its columns say what it holds (within_tol and unresolved are read as
# the consistency verdict by refsim.verdicts.upgrade_table). 3: `settings` holds values, its
# prose once per run in settings_text.json (refsim.store.settings_text; `expand` reads both).
# A newer format is refused.
FORMAT = 3


def new_run_id() -> str:
    return datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-" + secrets.token_hex(3)


class RunStore:
    WRITE_EVERY_S = 5.0  # results.csv refresh interval while rows arrive

    def __init__(self, run_dir: Path):
        self.dir = Path(run_dir)
        self.rows: list[dict] = []
        self._written = time.monotonic()

    @classmethod
    def create(cls, root: Path, manifest: dict) -> "RunStore":
        store = cls(Path(root) / manifest["run_id"])
        if store.dir.exists():
            raise ValueError(f"run directory {store.dir} already exists")
        store.write_manifest({"format": FORMAT, **manifest})
        return store

    @classmethod
    def open(cls, run_dir: Path) -> "RunStore":
        store = cls(run_dir)
        if not (store.dir / "manifest.json").exists():
            raise ValueError(f"run must be a stored run directory, no manifest in {store.dir}")
        if (store.dir / JOURNAL).exists():
            store.rows = read_journal(store.dir / JOURNAL)
        elif (store.dir / "results.csv").exists():
            store.rows = load_results(store.dir).to_dict("records")
        return store

    @property
    def manifest(self) -> dict:
        return json.loads((self.dir / "manifest.json").read_text())

    def write_manifest(self, manifest: dict) -> None:
        atomic_write(self.dir / "manifest.json", json.dumps(manifest, indent=2, default=str))

    def update_manifest(self, **fields) -> None:
        self.write_manifest({**self.manifest, **fields})

    def done_keys(self) -> set:
        return {row_key(r) for r in self.rows}

    def add(self, row: dict) -> None:
        if not hasattr(self, "_prose"):
            from refsim.store.settings_text import SettingsText
            self._prose = SettingsText(self.dir)
        row = self._prose.store_row(row)
        self.rows.append(row)
        with open(self.dir / JOURNAL, "a") as handle:
            handle.write(json.dumps(row, default=_plain) + "\n")
            handle.flush()
        if time.monotonic() - self._written > self.WRITE_EVERY_S:
            self.write_table(pd.DataFrame(self.rows))

    def add_series(self, row: dict, trace: dict) -> None:
        """Time series of one row (see runner.series), appended to `series.jsonl`."""
        line = json.dumps({"key": list(row_key(row)), **trace}, default=_plain)
        with open(self.dir / SERIES, "a") as handle:
            handle.write(line + "\n")

    def add_definitions(self, definitions: list[dict]) -> None:
        """Keep the cases as run (Case.definition + the row's `params` text under "key_params"):
        report and compare read these, never today's code. Earlier ones are kept."""
        known = {definition_key(d): d for d in load_definitions_list(self.dir)}
        for d in definitions:
            known.setdefault(definition_key(d), d)
        atomic_write(self.dir / DEFINITIONS, json.dumps(list(known.values()), indent=1,
                                                         default=_plain))

    def write_table(self, table: pd.DataFrame) -> None:
        self._written = time.monotonic()
        atomic_write(self.dir / "results.csv", table.to_csv(index=False, na_rep="nan"))
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            return
        tmp = self.dir / ".results.parquet.tmp"
        table.to_parquet(tmp, index=False)
        os.replace(tmp, self.dir / "results.parquet")


def _plain(value):
    """JSON for numpy scalars in a row."""
    return value.item() if hasattr(value, "item") else str(value)


def read_journal(path: Path) -> list[dict]:
    """Rows of `rows.jsonl`; a last line cut short by an interruption is dropped."""
    rows = []
    for line in Path(path).read_text().splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return rows


def definition_key(d: dict) -> tuple:
    return (d["case"], d["variant"], d["key_params"])


def load_definitions_list(run_dir: Path) -> list[dict]:
    path = Path(run_dir) / DEFINITIONS
    return json.loads(path.read_text()) if path.exists() else []


def load_definitions(run_dir: Path) -> dict:
    """{(case, variant, params text): definition} of a stored run; {} for a run stored before
    definitions were kept (refsim.store.definitions gives those today's definitions, saying so)."""
    return {definition_key(d): d for d in load_definitions_list(run_dir)}


def load_series(run_dir: Path) -> dict:
    """{row key: {"t": [...], "energy": [...], observable: [...]}} of a stored run."""
    path = Path(run_dir) / SERIES
    return {tuple(r.pop("key")): r for r in read_journal(path)} if path.exists() else {}


def _key_value(value):
    if value is None or (isinstance(value, float) and value != value):
        return ""
    if isinstance(value, float):
        return float(f"{value:.12g}")
    return str(value)


def row_key(row: dict) -> tuple:
    return tuple(_key_value(row[k]) for k in KEY)


# results columns that hold text (an empty string is a value there, not a missing number)
TEXT_COLUMNS = ("run_id", "case", "variant", "engine", "engine_variant", "integrator",
                "params", "engine_version", "status", "reason", "settings", "tol_reason",
                "timing", "within_tol", "tol_capped", "unresolved", "host", "consistency",
                "consistency_reason", "reaches_target", "order_note")


def run_format(run_dir: Path) -> int:
    """The stored run's format (1 when unstamped); ValueError for one newer than FORMAT."""
    path = Path(run_dir) / "manifest.json"
    found = json.loads(path.read_text()).get("format", 1) if path.is_file() else 1
    if not (isinstance(found, int) and 1 <= found <= FORMAT):
        raise ValueError(f"run format must be 1..{FORMAT} (this refsim's), {run_dir} has "
                         f"{found!r}: open it with the refsim that wrote it")
    return found


def load_results(run_dir: Path) -> pd.DataFrame:
    run_format(run_dir)
    table = pd.read_csv(Path(run_dir) / "results.csv", keep_default_na=False,
                        na_values=["nan"])
    for col in [c for c in table.columns if c not in TEXT_COLUMNS
                and not pd.api.types.is_numeric_dtype(table[c])]:
        # a number column written with "" for its missing values (pandas' default, as when
        # two runs' tables are merged by hand) is read as text: numbers again, "" as nan
        values = table[col].replace("", "nan")
        numbers = pd.to_numeric(values, errors="coerce")
        if numbers.notna().sum() == (values != "nan").sum():
            table[col] = numbers
    for col in ("variant", "engine_variant", "reason"):
        if col in table:
            table[col] = table[col].astype(str)
    # the column-by-column replacements above leave one block per column: consolidate, or
    # every later insert (the report's model_group column) warns of a fragmented frame
    table = table.copy()
    from refsim.verdicts import upgrade_table
    return upgrade_table(table)  # a run stored before the two verdicts reads with them


def environment(engine_versions: dict, case_hashes: dict, threads: int) -> dict:
    return {
        "git_commit": _git_commit(),
        "timestamp": datetime.now(timezone.utc).isoformat(),
        "python": sys.version.split()[0],
        "numpy": _version("numpy"), "scipy": _version("scipy"), "pandas": _version("pandas"),
        "platform": platform.platform(),
        "cpu": _cpu_model(),
        "threads": threads,
        "thread_env": {k: os.environ.get(k) for k in
                       ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")},
        "engines": engine_versions,
        "case_hashes": case_hashes,
    }


def _version(package: str) -> str:
    from importlib.metadata import version
    try:
        return version(package)
    except Exception:
        return "unknown"


def _git_commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=Path(__file__).resolve().parent, timeout=5)
        return out.stdout.strip() or "unknown"
    except Exception:
        return "unknown"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"
