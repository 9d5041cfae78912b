"""The study's vocabulary and the scaling problem built from it: design variables, study
files, tunnels, configurations, similarity parameters, the classical solution, objectives,
admissibility checks, the scatter of a tested model and ``ScalingProblem``. Imports no
other room of the workflow (``tests/test_layers.py``)."""
