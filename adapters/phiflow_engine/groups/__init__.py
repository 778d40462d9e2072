"""Model groups of the PhiFlow peer, found by refsim.engine.discover_groups (ARCHITECTURE.md):
grid_fluids only. Modules import PhiFlow lazily."""
