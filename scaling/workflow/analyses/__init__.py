"""After a run: what-ifs on a design, full-scale predictions from a measured test, the
best known design of a shipped study. Reads run directories through the campaigns room."""
