"""The DCS9 nine-node shell (Ch. 3): element kernels, assembly, static, modal, buckling and
transient analyses."""
