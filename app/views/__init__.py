"""Qt widgets of the app.

Importing this package sets pyqtgraph's image axis order to row-major, once,
before any image is made: every array here is ``(row, col)`` like the core's,
and without it every DEM would show transposed.
"""

import pyqtgraph as pg

pg.setConfigOptions(imageAxisOrder="row-major", antialias=True)
