"""Sub-commands of the ``torchrom`` CLI, one module each (see :mod:`torchrom.cli`)."""

# Order in ``torchrom --help``; commands not listed come after, alphabetically.
ORDER = [
    "paper", "goland", "modes", "static", "update", "identify", "aero", "flutter", "sweep", "plot",
    "branch", "calibrate", "bifurcation", "cache",
]
