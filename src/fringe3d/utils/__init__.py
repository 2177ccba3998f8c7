"""Ground utilities every layer may use: atomic writes, JSON reading, warning classes, console,
the software prefetch of the compiled sampled passes (private :mod:`fringe3d.utils._prefetch`).

Nothing here imports another fringe3d package. :mod:`fringe3d.utils.console` is for the
command layer (tables, progress bars, quiet mode); library code reports through
:mod:`warnings` with the classes in :mod:`fringe3d.utils.warning_types`.
"""
