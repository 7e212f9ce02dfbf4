"""Model files (TOML), the safe expression language of model files, and the command line.

Layer: the top.  It may import every other subpackage (model files build plants,
the command line runs designs, simulations, campaigns and deployments).
"""
