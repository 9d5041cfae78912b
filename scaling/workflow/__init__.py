"""The scaling workflow: the bridge between the engine and the simulator (study files,
tunnels, similarity, classical GP, the scaling problem, runs, sweeps, laws, what-ifs)."""
