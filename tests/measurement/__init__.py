"""Measurement: the benchmark, its throughput kernels, the heyoka race, the chaotic high-precision reference."""
