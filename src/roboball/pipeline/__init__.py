"""Pipeline stages: each is a plain function of input and output paths, called by one
Snakemake rule through `roboball stage NAME --arg value ...` (see roboball.cli.stage)."""
