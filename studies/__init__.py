"""Runnable study definitions (TOML) and scripts reproducing the dissertation.

Each study script exposes ``run(config) -> result`` and does nothing at import.
"""
