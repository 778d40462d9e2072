"""Model group `first_order_fields`: massless particles moved by a prescribed first-order field
(a rigid vortex, gradient descent, implicit-surface sampling; shared affine-field helpers in
`_affine`)."""
