"""Stored settings (store format 3): values in the row, prose once per run
(refsim/store/settings_text.py)."""
import json

from refsim.run.job import Job, run_job
from refsim.store.results import FORMAT, RunStore, load_results
from refsim.store.settings_text import TEXT_FILE, expand, load_texts, split

SETTINGS = {"integrator": {"name": "rk4", "order": 4, "symplectic": False,
                           "family": "explicit Runge-Kutta"},
            "dtype": "float64", "threads": 1, "contact_model": "soft",
            "formulation": "generalized coordinate (hinge angle)",
            "notes": ["one sentence here", 3.5, "x64"]}


def test_split_keeps_values_and_tokens_the_prose():
    texts = {}
    values, paths = split(SETTINGS, texts)
    assert values["integrator"]["order"] == 4 and values["contact_model"] == "soft"
    assert values["dtype"] == "float64" and values["notes"][1:] == [3.5, "x64"]
    assert set(paths) == {"integrator.family", "formulation", "notes[0]"}
    assert not any(" " in v for v in json.dumps(values).split('"') if v.startswith("text:"))
    assert expand(values, texts) == SETTINGS
    assert expand(SETTINGS, {}) == SETTINGS  # a format-2 row: nothing to expand


def test_a_stored_run_keeps_prose_once(tmp_path):
    st = RunStore.create(tmp_path, {"run_id": "r1"})
    assert st.manifest["format"] == FORMAT == 3
    rows = [run_job(Job("free_fall", "default", "refsim", "", integrator, 1e-2), repeats=0)
            for integrator in ("rk4", "symplectic_euler")]
    for row in rows:
        st.add(row)
    texts = load_texts(st.dir)
    stored = json.loads((st.dir / TEXT_FILE).read_text())
    assert set(stored["texts"]) == set(texts) and "refsim/" in stored["by_formulation"]
    st.write_table(__import__("pandas").DataFrame(st.rows))
    table = load_results(st.dir)
    for row, kept in zip(rows, table.settings):
        assert expand(json.loads(kept), texts) == json.loads(row["settings"])
        assert not any(c.isspace() for leaf in _leaves(json.loads(kept)) if
                       isinstance(leaf, str) for c in leaf)
    # each text once in the file, however many rows declared it
    assert len(texts) == len(set(texts.values()))


def _leaves(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from _leaves(v)
    elif isinstance(value, list):
        for v in value:
            yield from _leaves(v)
    else:
        yield value
