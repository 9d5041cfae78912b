"""Layer-wise HTSH thermal finite elements (Ch. 4): reference kernels (element), the model
(model) and the Crank-Nicolson march (march); the banded factorizations are in
``hypate.solvers.numerics.banded``."""
