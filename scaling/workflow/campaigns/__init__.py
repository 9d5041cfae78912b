"""Campaigns: the runner (``execute``) and what it runs -- one study, seeds, a robust
study, a sweep with its refined scaling laws -- and the run directory they write (outputs,
the run-directory contract, integrity, sessions). Imports the vocabulary only."""
