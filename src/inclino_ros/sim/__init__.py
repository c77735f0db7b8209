"""Virtual bench and well: readings from a known truth, for the CLI, tests and benchmarks only."""
