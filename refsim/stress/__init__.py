"""`refsim stress`: stability limits and a stiffness sweep on the undamped stiff spring.

1. Stability limits. For every engine and every fixed-step integrator it offers (adaptive ones
   and those `supports` rejects are skipped): the largest stable y = omega dt, by bisection
   (refsim.stress_search: batched over y in the in-house engine, one Sim per y elsewhere).
   Criterion: stable when, at every step over P periods (default 1000; at most 10 P steps),
   the state is finite, the engine reports no failure and the energy stays below F E0,
   F = 1e4 (`Criterion.text`, `f_reason`). Scene: the stiff-spring case with amplitude 1e-7 m,
   other parameters default, so the spring stays linear (stress_search.SPRING_PARAMS says
   why); the sweep uses the same. Columns: measured limit; theory (from the stepper's
   declared family / tableau: symplectic Euler, Verlet 2; RK4 2 sqrt 2; dopri5 0.99719;
   explicit Euler, midpoint, Heun, RK2 0; implicit unbounded);
   finite_time, the y the stated criterion must give from the method's exact step map;
   resolution = |finite_time - theory| plus the overshoot allowance; agrees: |measured -
   theory| <= resolution + bisection tolerance x max(1, theory), or both unbounded.
2. Stiffness sweep. k = 1e1 .. 1e8 N/m (m = 1 kg, y = sqrt(k) dt) at dt = 1e-3 s (--dt), on
   every engine's default integrator (symplectic Euler where offered, else its first) and the
   named ones it offers (SWEEP_NAMED), each run min(20 periods, 2 s) observed every step.
3. Failure taxonomy (column `failure`, `LEGEND`): each run goes to its end, or until the
   engine reports a failure or the state turns non-finite; the most telling label wins:
   - silent_reset: the engine reported a state on which it silently resets (MuJoCo's bad
     qpos/qvel/qacc warning: MuJoCo would reset to the initial pose and go on; the adapter
     turns the reset off and reports it as `Sim.failure`), or the state returned bitwise to
     the initial one after the energy had reached F E0;
   - engine_failure: any other breakdown the engine reported (`Sim.failure`, e.g. refsim's
     Newton non-convergence);
   - nan_inf: a non-finite position or velocity;
   - energy_growth: energy >= F E0 at some step, the state still finite;
   - artificial_damping: none of the above, and energy < 1 % of E0 at the end (undamped run);
   - none: none of these; error: the run raised (not a physics outcome).
   `at_step` is the step of the labelled event; `detail` the engine's message and when the
   energy first reached F E0.
4. Store: stress_limits.csv, stress_sweep.csv and manifest.json in a new run directory under
   --out (default reports/runs), and the same figures as an ordinary stored run there
   (results.csv, rows.jsonl, cases.json: refsim.stress_store) that `refsim report` and
   `refsim compare` read; both tables are printed with the directory. Exit 0: a measured
   instability is data.
"""
