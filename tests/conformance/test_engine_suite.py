"""The built-in engines pass the suite third parties are told to run on theirs
(refsim.testing.engine_suite, README "Checking your own engine"): every job of the cases below
that the engine supports (each variant a plain `refsim run` covers x engine variant x
integrator, at the case's reference dt) runs to the end and is not inconsistent with the method
it names.

A small, fast subset per engine (CI's time budget is nearly used up; the whole suite per engine
is `refsim run`'s job), timed serially on a 2-core machine: pybullet, mujoco, pymunk: free_fall
and stiff_spring, 7, 35 and 8 jobs, 0.5 to 1.3 s. refsim: lj_dimer, 4 jobs, 0.3 s (its
free_fall, 28 jobs and 4 s, is checked row by row against its bounds in
tests/cases/test_free_fall.py). taichi: kepler, 3 jobs, 2 s with its kernels' compilation (its
free_fall is 12 jobs and 10 s). engine_suite skips an engine that is not installed, as a third
party's CI would; .ci/run fails first when one of the four engines does not import, and the
engines' own test files fail without theirs (fail, never skip).
"""
from refsim.testing import engine_suite

test_refsim = engine_suite("refsim", cases=["lj_dimer"])
test_pybullet = engine_suite("pybullet", cases=["free_fall", "stiff_spring"])
test_mujoco = engine_suite("mujoco", cases=["free_fall", "stiff_spring"])
test_pymunk = engine_suite("pymunk", cases=["free_fall", "stiff_spring"])
test_taichi = engine_suite("taichi", cases=["kepler"])
