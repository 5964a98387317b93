"""The gradient optimiser: Adam on image objectives, for the fit's paths that need it (``--no-discover``, the
superquadrics grown beside ``--outline hull``, a fixed ``--superquadrics`` count, ``--iterations``).

- :mod:`.targets`     per-view masks, line maps and distance fields; batched projection
- :mod:`.objectives`  pluggable objectives (``edges``: the weight-free default)
- :mod:`.params`      torch parameterisation of curves and superquadrics
- :mod:`.optimize`    one Adam stage with progress, checkpoints and Ctrl-C
- :mod:`.grow`        superquadrics grown against the silhouettes, one move at a time
- :mod:`.init`        farthest-point starts on SfM points or the visual hull
- :mod:`.prune`       after the curve stage: keep curves that lie on the views' lines
"""
