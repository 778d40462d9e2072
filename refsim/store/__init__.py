"""Stored runs: `results` writes a run directory (manifest, results, definitions) atomically and
loads it back, `runs` opens stored runs for `report` and `compare`, `definitions` keeps the cases
as a run ran them, `figures` stores figures that are not matrix rows (stress, bench) as ordinary
runs."""
