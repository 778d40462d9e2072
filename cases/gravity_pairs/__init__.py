"""Model group `gravity_pairs`: particles under mutual Newtonian gravity (Kepler orbit, the
three-body figure eight; shared orbit bounds in `_orbits`)."""
