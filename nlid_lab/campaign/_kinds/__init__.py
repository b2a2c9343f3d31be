"""The excitation kinds campaigns run, one module per kind: its plan class (a `LevelPlan`
registered with `register_plan`) and its level loop (`LevelPlan.run`, on the runner's
primitives, `Runner`).

Importing this package imports every module in it (`discover_kinds`), so a new kind is one
new module here (and its output record in `drivers.outputs` when the shaker plays a new
waveform): no list of kinds to edit. The modules are imported in name order, the order
`PLANS` (and the messages listing the kinds) name them.
"""

from .._plans import discover_kinds

discover_kinds(__name__, __path__)
