"""numpy twins and references of the chapters that only the tests use (``from reference.X import ...``)."""
