"""The pages made from the stores: one per sweep (benchmarks/pages/NAME.md) and BENCHMARKS.md."""
