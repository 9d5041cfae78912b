"""Fluid-thermal-structural coupling (Ch. 5): load/displacement transfer, the panel
model, the TC and LC S1/S2 schemes, linearized stability, flutter and the response."""
