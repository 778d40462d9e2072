"""Model group `pivots`: rigid bodies hinged at a fixed pivot (the rigid-body algebra and bounds
they share are in refsim_cases.rigid)."""
