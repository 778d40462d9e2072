"""refsim: reference validation and benchmarking for physics simulation engines."""
__version__ = "0.1.0"
