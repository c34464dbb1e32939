"""Stage 6, measurement: work-precision benchmarks, peers, and the trust horizon."""
