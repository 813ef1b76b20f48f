"""The evaluations of the ``evaluation`` cell kind (ksbo_bench.kinds.evaluate): one module each."""
