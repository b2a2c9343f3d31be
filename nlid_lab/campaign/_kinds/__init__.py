"""The excitation kinds campaigns run, one module per kind: its plan class (a `LevelPlan`
registered with `register_plan`) and its level loop (`LevelPlan.run`, on the runner's
primitives, `Runner`).

Importing this package imports every module in it, so a new kind is one new module here
(and its output record in `drivers.outputs` when the shaker plays a new waveform): no list
of kinds to edit. `pkgutil.iter_modules` lists the package's modules in name order, which is
the order `PLANS` (and the messages listing the kinds) name them.
"""

import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")
