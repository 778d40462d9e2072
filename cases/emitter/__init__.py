"""Model group `emitter`: particles born by an emitter (a sprinkler)."""
