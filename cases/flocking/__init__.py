"""Model group `flocking`: boids under the flocking rules."""
