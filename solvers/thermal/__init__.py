"""Layer-wise HTSH thermal finite elements (Ch. 4), one room per responsibility: reference
kernels (element), the hexahedron mesh (mesh), boundary conditions (loads), the volume terms
(assembly), the boundary terms (boundary), residual, Jacobian and Newton (newton), the model
with its outputs (model), the Crank-Nicolson march (march) and heater schedules (schedule);
the banded factorizations are in ``hypate.solvers.numerics.banded``."""
