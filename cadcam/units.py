"""The units reports and files show beside SI, each declared once as its size in the SI unit
(cadcam computes in SI; a value times the constant is the value in the unit named)."""

#: Millimetres per metre (and newton-millimetres per newton-metre): the length unit of every
#: exported file (the DXF's $INSUNITS = 4, a groove's columns ``_mm``), the drawings and reports.
MM = 1e3
#: Micrometres per metre (the output error's axis).
UM = 1e6
