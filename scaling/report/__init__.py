"""The run report, in four modules, each importing only those before it: ``rundata`` (the
run directory read into a RunData), ``figures`` (matplotlib), ``sections`` (the page's
sections) and ``html`` (the self-contained page and the section plug-in registry)."""
