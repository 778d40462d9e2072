"""Speed benchmarks, one module each, found through the `refsim.benches` entry points
(`refsim bench NAME`); each module offers `main(quick: bool) -> int` and prints its figures
side by side in one run."""
