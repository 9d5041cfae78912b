"""Layer-wise HTSH thermal finite elements (Ch. 4) and the Crank-Nicolson march."""
