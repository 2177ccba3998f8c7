"""Analysis of measured point maps: shape fits and VDI/VDE 2634-2-style accuracy figures
(:mod:`.fits`, :mod:`.vdi`, :mod:`.sections`), geodesics, tracking and strain of membranes
(:mod:`.geodesic`, :mod:`.tracking`, :mod:`.strain`). Import the submodule you need."""
