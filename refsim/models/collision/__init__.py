"""The in-house collision detection (issue 28; slides 001 and 000: separating axes, signed
distance fields, bounding volume hierarchies, discrete against continuous detection), each
vectorised over its batch of queries: `swept` (swept-sphere time of impact), `sat` (separating
axes for convex polygons and oriented boxes), `sdf` (grid signed distance fields, trilinear),
`bvh` (a bounding volume hierarchy over spheres). No Python loop over pairs or queries."""
