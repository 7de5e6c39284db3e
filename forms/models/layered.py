"""Former home of the layered 1D model, now :mod:`forms.models.section` (the one 1D model).

Kept as names only: ``LayeredModel`` is :class:`forms.models.section.SectionModel`; the stack
types and constructors are re-exported for the 2D model (:mod:`forms.models.layered_strip`)
and older callers.
"""

from forms.models.section import (
    END_CONDITIONS,
    Layer,
    SectionModel,
    Stack,
    layer_coefficients,
    pml_layers,
    pml_stack,
    stack_from_layers,
    stack_from_params,
)

#: The one 1D model under its former name.
LayeredModel = SectionModel

__all__ = ["END_CONDITIONS", "Layer", "LayeredModel", "SectionModel", "Stack",
           "layer_coefficients", "pml_layers", "pml_stack", "stack_from_layers",
           "stack_from_params"]
