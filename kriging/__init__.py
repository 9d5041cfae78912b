"""Neutral kriging core shared by the optimization engine (``scaling``) and the fluid ROM
(``solvers.aero.rom``): it imports neither, so both may import it (DESIGN.md, "Which part
may know which": one kriging implementation, not two)."""
from kriging.gp import KERNELS, KrigingRegressor, kernel_matrix

__all__ = ["KERNELS", "KrigingRegressor", "kernel_matrix"]
