"""The finite-element model group's physics: P1 triangles and tetrahedra.

elements (shape gradients, volumes, the gradient operator), laws (linear/Cauchy, Green/StVK,
corotated, Neo-Hookean, plane strain), plasticity (ideal and hardening von Mises), model (an
elastic body: mesh + law), assembly (forces and tangent stiffness into scipy.sparse, the pattern
found once), printed (the slide's printed nodal force as a formulation), system (the body as a
system for the steppers, lumped or consistent mass), static (Newton to equilibrium), poisson
(P1 Poisson on triangles), meshes and cantilever (mesh generators and the Timoshenko field).
Nothing here steps time.
"""
