"""The multi-objective Bayesian-optimization engine: any pymoo problem, kriging surrogates,
acquisitions, SLSQP multistart, the crash-safe store and executors. Knows numpy, scipy,
scikit-learn, pymoo and ``hypate.solvers.numerics`` only."""
