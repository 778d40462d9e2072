"""Model group `contact_rolling`: a rigid body rolling on a wall with friction (the rigid-body
algebra is in refsim_cases.rigid)."""
