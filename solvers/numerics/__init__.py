"""Numerical kernels shared by the simulator and the optimization engine: sparse and
banded factorization, BLAS-thread limits, random sampling and the kriging core. Imports
nothing else of ``solvers`` (DESIGN.md, "Which part may know which")."""
