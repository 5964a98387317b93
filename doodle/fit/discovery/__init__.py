"""Stroke discovery: posed, masked images → candidate 3D cubics → the chosen curves.

The pipeline, in the order it runs (in :mod:`.discover`: ``trace_candidates``, whose traces do not depend on the
outline drawn, ``find_candidates`` that offers them, then ``choose_curves``):

- :mod:`.evidence`    the visual hull on a grid fitted to the object, and the 3D edge vote of every view's lines
- :mod:`.ridges`      ridge points of the vote, traced into polylines, split at corners
- :mod:`.rims`        each training view's outline traced into 3D (contour curves)
- :mod:`.sightlines`  where the views see curves inside the hull (cleared from it)
- :mod:`.texture`     which candidates lie on smooth faces of the hull (print, not structure)
- :mod:`.facing`      each curve's two face normals (from where it is seen)
- :mod:`.discover`    candidate cubics, their coverage, the greedy choice, polish and joins
"""
