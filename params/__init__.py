"""Vehicle profiles (TOML data files), installed as the data package ``ksbo_params``."""
