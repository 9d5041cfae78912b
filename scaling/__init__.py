"""hypate scaling: the multi-objective Bayesian-optimization engine, the two-pronged
scaling workflow, reports and the ``hypate`` command line."""
