"""Model group `sph`: SPH water in a tank (one scenario per module; shared tank helpers in
`_sph_tank`)."""
