"""The tests, by pipeline stage (one folder per stage of derive), the system tests and the oracles."""
