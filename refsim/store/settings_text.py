"""A row's `settings` as stored: machine-readable values in the row, prose once per run.

`Sim.settings()` mixes values (numbers, booleans, names such as "float64", "soft", "DIRECT")
with prose (sentences saying how the engine was driven and why). Stored as they come, the
prose is repeated on every row of an engine (over half the bytes of results.csv). So the
store splits them (store format 3): a string leaf holding whitespace is prose; it is replaced
in the row by a token "text:<id>" (id: the first 10 hex digits of its SHA-256) and written
once to `settings_text.json` in the run directory, with an index of the prose paths each
(engine, formulation) declared. `expand` puts the prose back. Runs of format 2 and earlier
hold their prose in the rows: `expand` leaves them as they are.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from refsim.store.atomic import atomic_write

TEXT_FILE = "settings_text.json"
TOKEN = "text:"


def _is_prose(value) -> bool:
    return isinstance(value, str) and any(c.isspace() for c in value)


def text_id(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def split(settings, texts: dict, path: str = "") -> tuple:
    """(settings with every prose leaf replaced by its token, {path: id} of those leaves);
    the prose itself is added to `texts` (id -> text)."""
    if isinstance(settings, dict):
        out, paths = {}, {}
        for key, value in settings.items():
            out[key], found = split(value, texts, f"{path}.{key}" if path else str(key))
            paths.update(found)
        return out, paths
    if isinstance(settings, list):
        out, paths = [], {}
        for k, value in enumerate(settings):
            item, found = split(value, texts, f"{path}[{k}]")
            out.append(item)
            paths.update(found)
        return out, paths
    if _is_prose(settings):
        ident = text_id(settings)
        texts[ident] = settings
        return TOKEN + ident, {path: ident}
    return settings, {}


def expand(settings, texts: dict):
    """The settings with every token replaced by its prose (unknown tokens kept)."""
    if isinstance(settings, dict):
        return {k: expand(v, texts) for k, v in settings.items()}
    if isinstance(settings, list):
        return [expand(v, texts) for v in settings]
    if isinstance(settings, str) and settings.startswith(TOKEN):
        return texts.get(settings[len(TOKEN):], settings)
    return settings


class SettingsText:
    """The prose of one run directory: {"texts": {id: text}, "by_formulation":
    {"engine/formulation": {path: [ids]}}}, rewritten (atomically) when a row brings new prose."""

    def __init__(self, run_dir: Path):
        self.path = Path(run_dir) / TEXT_FILE
        data = json.loads(self.path.read_text()) if self.path.is_file() else {}
        self.texts = data.get("texts", {})
        self.by_formulation = data.get("by_formulation", {})

    def store_row(self, row: dict) -> dict:
        """The row with its settings (a JSON text) split; new prose written to the file."""
        raw = row.get("settings")
        if not isinstance(raw, str) or not raw.strip().startswith("{"):
            return row
        before = (len(self.texts), sum(len(v) for d in self.by_formulation.values()
                                       for v in d.values()))
        values, paths = split(json.loads(raw), self.texts)
        index = self.by_formulation.setdefault(
            f"{row.get('engine', '')}/{row.get('engine_variant', '')}", {})
        for key, ident in paths.items():
            known = index.setdefault(key, [])
            if ident not in known:
                known.append(ident)
        after = (len(self.texts), sum(len(v) for d in self.by_formulation.values()
                                      for v in d.values()))
        if after != before:
            atomic_write(self.path, json.dumps({"texts": self.texts,
                                                "by_formulation": self.by_formulation},
                                               indent=1, sort_keys=True))
        return {**row, "settings": json.dumps(values)}


def load_texts(run_dir: Path) -> dict:
    """id -> prose of a stored run ({} for a run of format 2 or earlier)."""
    path = Path(run_dir) / TEXT_FILE
    return json.loads(path.read_text()).get("texts", {}) if path.is_file() else {}
