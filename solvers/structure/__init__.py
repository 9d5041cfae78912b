"""The DCS9 nine-node shell (Ch. 3): element kernels and assembly (element, model), static
equilibrium (static), modes and buckling (modal), and the one generalized-alpha integrator
(dynamics)."""
