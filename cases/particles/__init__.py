"""Particle cases: point masses under gravity, springs and rods (one scenario per module)."""
