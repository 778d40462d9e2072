"""Scene translation every adapter shares, written once (physics-neutral: no engine maps here).

- `checks`: the scene refusals several engines give (walls without a contact model, contact
  bodies that are not spheres or lack a moment of inertia, rods per body, springs between two
  bodies or on a rod's body, linear drag); each returns None or "<who>: <reason>", `who`
  naming the engine as its messages always have ("pybullet adapter", "refsim joints" ...);
- `hinges`: a rod's start geometry check, the hinge frames and angles of every rod
  (`HingeFrames`) and the rod-length error observation;
- `contacts`: the per-shape sqrt(e), sqrt(mu) whose pair product is the scene's e, mu (wall
  points and normals are the scene's own arrays, `scene.part(Walls)`);
- `sph_lattice`: the fluid and wall particle lattices of an SPH fluid block, its gravity in the
  plane and its hydrostatic start densities.
"""
