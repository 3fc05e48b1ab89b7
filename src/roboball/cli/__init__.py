"""Command lines: `roboball` (simulate, urdf, check-config), its subcommands `stage`,
`diagnose` and `report`, each registered by its own module."""
