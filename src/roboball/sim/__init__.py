"""Drake side of roboball: plant building, scenarios, force systems, simulation runs."""
import logging


class _DropHalfSpaceDeformableWarning(logging.Filter):
    """Drake warns that a rigid half-space cannot take part in *deformable* contact; the project
    has no deformable bodies (the shell is compliant-hydroelastic), so the warning is noise."""

    def filter(self, record):
        return "not currently supported for deformable contact" not in record.getMessage()


logging.getLogger("drake").addFilter(_DropHalfSpaceDeformableWarning())
