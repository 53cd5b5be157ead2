"""External benchmarks: independent reference implementations of published problems (no CLI, no I/O)."""
