"""Compact aerothermoelastic (ATE) simulator for hypersonic skin panels.

The simulator is the expensive objective of the scaling optimizer. It never imports
``scaling`` (DESIGN.md, "Which part may know which").
"""
