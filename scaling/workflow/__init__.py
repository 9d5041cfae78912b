"""The scaling workflow: the bridge between the engine and the simulator, in three rooms
read in order -- ``vocabulary`` (study files, variables, tunnels, similarity, classical
scaling, the scaling problem), ``campaigns`` (the runner, runs, seeds, robust studies,
sweeps and laws, the run directory) and ``analyses`` (what-ifs, predictions, best known
designs). A room imports only the rooms before it (``tests/test_layers.py``)."""
