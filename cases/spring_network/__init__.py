"""Model group `spring_network`: mass-spring cloth, rope and hair (slides 000-002, issue 16):
`SpringNetwork` scenes with exact discrete references (hanging chain, string and membrane modes,
hair cantilever) and a cloth against the converged in-house solution."""
