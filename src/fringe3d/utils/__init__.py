"""Ground utilities every layer may use: atomic writes, JSON reading, warning classes, console.

Nothing here imports another fringe3d package. :mod:`fringe3d.utils.console` is for the
command layer (tables, progress bars, quiet mode); library code reports through
:mod:`warnings` with the classes in :mod:`fringe3d.utils.warning_types`.
"""
