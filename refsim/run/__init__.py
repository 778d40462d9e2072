"""Running the matrix: `runner` expands and runs it, `executors` say where the jobs run (local
worker processes or a Dask cluster), `sandbox` isolates one job in its process, `job` runs one
case x engine x integrator x dt and measures it (`metrics`: errors, energy drift, timing),
`summary` prints progress and the summary table."""
