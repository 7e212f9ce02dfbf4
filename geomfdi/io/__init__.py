"""Model files (TOML), the safe expression language of model files, and the command line."""
