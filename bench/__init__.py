"""Benchmarks as declared sweeps: ``ksbo-bench run benchmarks/sweeps/NAME.toml`` runs every cell a sweep file
declares (one campaign or one evaluation each) on this machine's processes or on a Ray cluster, and writes one
record per cell, in one schema, to the sweep's store; ``ksbo-bench report`` makes the pages from the stores.

The tuner never imports this package: it is a user of ksbo_mav and ksbo_sim, like a researcher's script.
"""
