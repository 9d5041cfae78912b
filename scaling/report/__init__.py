"""The run report: run data, figures and the self-contained HTML page."""
