"""labjoint: bolted-joint dynamics lab service.

Layers, lowest first (a layer never imports a higher one):
``errors``/``config`` -> ``hardware`` -> ``acquisition`` -> ``storage`` -> ``signal``
-> ``identify`` -> ``models`` -> ``compare`` -> ``api``/``cli``/``web``.
"""

__version__ = "0.1.0"
