"""Contact cases: spheres meeting by impacts (one scenario per module; shared impact
helpers in `_impact`)."""
