"""Scripts reproducing the dissertation; each exposes ``run(config) -> result`` and does
nothing at import (``python -m hypate.studies.scripts.NAME``)."""
