"""Model groups of this engine added as files: each module here defines MODEL_GROUP =
refsim.engine.ModelGroup(...) and is found by refsim.engine.discover_groups (ARCHITECTURE.md).
Modules import the engine package lazily."""
