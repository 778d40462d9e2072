"""Speed benchmarks, one module each, found through the `refsim.benches` entry points
(`refsim bench NAME`); each module offers `main(quick: bool) -> list[dict]`: it prints its
figures side by side in one run and returns them as data (one dict per figure, the contract in
refsim.store.figures), which `refsim bench` stores as an ordinary run that `refsim report` and
`refsim compare` read. A main that returns an int (an exit code) is run and nothing stored."""
