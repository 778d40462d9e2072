"""Model group `collision`: geometric queries with exact answers (issue 28; slides 001 and
000): separating axes, signed distance fields, bounding volume hierarchies, swept spheres
(query cases, refsim.query), and tunnelling in time stepping."""
