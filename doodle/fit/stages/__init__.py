"""The fit's stages, one module each, in the order :func:`doodle.fit.pipeline.fit` runs them:

- :mod:`.prepare`        check the options, working-size images, seeds, the path (:class:`~doodle.fit.state.Plan`)
- :mod:`.volume`         carve the visual hull once: the grid, the hull's outline, the occluder
- :mod:`.discover`       candidate curves from the multi-view edge evidence (or start points for the gradient path)
- :mod:`.superquadrics`  abstract / grow / fixed, and which outlines are drawn
- :mod:`.curves`         the final choice beside the outlines, the gradient polish, hiding
- :mod:`.assemble`       the stroke set (after an interruption: what the finished stages give)

Each reads and fills a :class:`~doodle.fit.state.FitState`; each but ``prepare`` and ``assemble`` has ``NAME``
and ``run(state)``.
"""
