"""The evaluations of the ``evaluation`` cell kind (ksbo_bench.kinds.evaluation): one module each."""
