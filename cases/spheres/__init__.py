"""Model group `spheres`: spheres meeting by impacts under a contact model (one scenario per
module; shared impact helpers in `_impact`)."""
