"""Model group `lennard_jones`: particles under Lennard-Jones pair forces (a dimer, a gas)."""
