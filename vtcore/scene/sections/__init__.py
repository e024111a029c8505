"""Scene tables and the builders that turn them into vtcore objects (one module per owner)."""
