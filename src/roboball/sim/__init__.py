"""Drake side of roboball: plant building, scenarios, force systems, simulation runs."""
