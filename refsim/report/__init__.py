"""Reading stored runs: `build` writes report.md and report.html (`overview`, `limits`, `plots`,
`render`, `style` draw its parts), `compare` judges two runs row by row."""
