"""Stored runs as `compare` and `report` open them: a run directory given as a path or a run id,
its rows by key, its stored case definitions, and the renaming of reorganised cases."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from refsim.store.definitions import Definitions
from refsim.store.results import DEFAULT_ROOT, KEY, load_results, row_key


@dataclass
class Run:
    dir: Path
    manifest: dict
    rows: dict  # row_key -> row (a key found twice, only by hand-editing, keeps its last row)
    definitions: Definitions = field(default_factory=lambda: Definitions({}))
    renamed: dict = field(default_factory=dict)  # new case name -> the name A stored it as


def parse_renames(specs) -> list[tuple]:
    """`OLD=NEW` or `OLD/VARIANT=NEW/VARIANT` -> [(old case, old variant or None, new case,
    new variant or None)]."""
    out = []
    for spec in specs or []:
        old, sep, new = str(spec).partition("=")
        (oc, _, ov), (nc, _, nv) = old.partition("/"), new.partition("/")
        if not sep or not oc or not nc or bool(ov) != bool(nv):
            raise ValueError(f"--rename must be OLD=NEW or OLD/VARIANT=NEW/VARIANT, got "
                             f"{spec!r}")
        out.append((oc, ov or None, nc, nv or None))
    return out


def rename_rows(run: Run, renames) -> Run:
    """Run A with its rows' case (and variant) names mapped; the definitions and the manifest's
    case hashes are looked up under the stored names."""
    if not renames:
        return run
    rows, renamed = {}, dict(run.renamed)
    for row in run.rows.values():
        row = dict(row)
        for oc, ov, nc, nv in renames:
            if row["case"] == oc and (ov is None or row["variant"] == ov):
                renamed[(nc, nv or row["variant"])] = (oc, row["variant"])
                row["case"], row["variant"] = nc, nv or row["variant"]
                break
        rows[row_key(row)] = row
    return Run(run.dir, run.manifest, rows, run.definitions, renamed)


def stored_name(run: Run, row: dict) -> tuple:
    """(case, variant) as run A stored them, before any --rename."""
    return run.renamed.get((row["case"], row["variant"]), (row["case"], row["variant"]))


def open_run(name: str, path) -> Run:
    """A stored run: a directory holding results.csv and manifest.json, given as a path or as
    a run id under reports/runs."""
    run_dir = Path(path)
    if not run_dir.is_dir() and (DEFAULT_ROOT / str(path)).is_dir():
        run_dir = DEFAULT_ROOT / str(path)
    if not ((run_dir / "results.csv").is_file() and (run_dir / "manifest.json").is_file()):
        raise ValueError(f"{name} must be a stored run directory (results.csv + "
                         f"manifest.json), got {str(path)!r}")
    try:
        manifest = json.loads((run_dir / "manifest.json").read_text())
        table = load_results(run_dir)
    except (ValueError, pd.errors.ParserError) as exc:
        raise ValueError(f"{name} must be a readable stored run, {run_dir}: "
                         f"{str(exc).splitlines()[0]}") from None
    missing = [k for k in KEY if k not in table]
    if missing:
        raise ValueError(f"{name} must be a stored run with columns {KEY}, "
                         f"{run_dir}/results.csv lacks {missing}")
    return Run(run_dir, manifest, {row_key(r): r for r in table.to_dict("records")},
               Definitions.of_run(run_dir))
